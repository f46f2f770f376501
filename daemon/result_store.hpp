// What robots get when they send GET,<job> (PROTOCOLS.md): a fresh result is delivered once
// per robot (again only with GET,<job>,LAST); while a cycle is running or until one
// arrives the request waits, up to the robot's reply deadline, then gets
// 2 RESULT_NOT_READY (a cycle is running) or 3 NO_NEW_TRIGGER (nothing triggered).
// Lives on the I/O thread: every method must be called there (post from elsewhere).
#pragma once

#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>

#include "core/cycle.hpp"
#include "protocol/robot_server.hpp"

namespace boost::asio {
class io_context;
}

namespace vgr::daemon {

class ResultStore {
 public:
  explicit ResultStore(boost::asio::io_context& io, std::set<int> knownJobs);
  ~ResultStore();

  void onCycleStarted(std::uint32_t cycleId, int jobId);
  void onResult(const CycleResult& result);
  // deadlineMs: the robot's reply deadline; a reply is always sent within it.
  void handleGet(const std::string& robot, const protocol::RobotRequest& req, protocol::ReplyFn reply, int deadlineMs);

  static protocol::RobotReply toReply(const CycleResult& r);

 private:
  struct Waiter;
  void answer(Waiter& w, const protocol::RobotReply& reply);

  boost::asio::io_context& io_;
  std::set<int> knownJobs_;
  std::map<int, CycleResult> latest_;                       // per job
  std::map<std::string, std::uint32_t> delivered_;          // robot -> last cycle id delivered
  std::optional<std::uint32_t> running_;                    // cycle in progress
  std::map<std::uint64_t, std::shared_ptr<Waiter>> waiters_;
  std::uint64_t nextWaiter_ = 1;
};

}  // namespace vgr::daemon
