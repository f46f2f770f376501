// What robots get when they ask (PROTOCOLS.md, "GET semantics"):
//  - GET,<job> (or GET = the robot's current job): the next part of the latest result of
//    that job not yet delivered to this robot. Parts of one image are served one per
//    request in the robot's PartOrder (paper 002's sorting strategies); each part goes to
//    each robot once (per robot name, so a reconnect does not repeat it). A part counts as
//    delivered only once its reply reached the robot's connection (protocol::WrittenFn):
//    one handed to a connection that closed, was replaced or reset before it got it goes
//    back and is the first served on that robot's next GET (unless a newer result of the
//    job arrived meanwhile: the robot then goes on with the newest).
//  - When nothing undelivered exists the request waits for the next result of that job,
//    up to the robot's reply deadline, then gets 2 RESULT_NOT_READY (a cycle is running) or
//    3 NO_NEW_TRIGGER (nothing triggered). A result answers the requests waiting for it,
//    oldest first, each with its robot's next part; a part goes to one connection of a
//    robot only: when a robot has more waiting connections than parts, the extra ones go
//    on waiting (next result or deadline), they never get a part another connection got.
//  - A result without parts (or none with the robot's label) is delivered once as
//    1 NO_PART_FOUND; an error result once with its status (-9 OFFSET_OUT_OF_LIMITS when
//    every part found was outside the job's limits: those parts are never served).
//  - What a part's reply carries depends on the robot's policy (deliver / frame in
//    cell.yaml, protocol/robot_frames.hpp): its pose in the user frame or its offset from
//    the job's taught reference (CycleResult::reference).
//  - GET,<job>,LAST: the reply this robot last got from the latest result again (the first
//    part in its order if it got none yet); 3 at once when the job never produced a result
//    and no cycle is running.
//  - JOB,<n>: the robot's current job becomes n (0 OK, or -7 for an unknown job), kept
//    across reconnects until the daemon restarts.
//  - TRIG[,<job>]: the robot asks for a part with no PLC in the loop: a cycle of the job is
//    triggered (TriggerSource::Robot) and the request waits for THAT cycle's result, served
//    like GET (its next part in the robot's order), up to the reply deadline, then
//    2 RESULT_NOT_READY; -3 BUSY_OVERRUN at once when the cycle queue is full. An
//    eye-in-hand snapshot (TRIG,<job>,<pose>, or GET with a pose) is a TRIG whose cycle
//    maps with the flange pose it carries.
// Unknown job anywhere: -7 JOB_NOT_FOUND.
// Lives on the I/O thread: every method must be called there (post from elsewhere).
#pragma once

#include <cstdint>
#include <functional>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "protocol/robot_frames.hpp"
#include "protocol/robot_server.hpp"

namespace boost::asio {
class io_context;
}

namespace vgr::daemon {

using PartOrder = config::PartOrder;

struct RobotPolicy {
  int job = 0;                // default job for "GET"; 0 = the smallest known job
  int replyDeadlineMs = 1500; // ms, > 0: a waiting GET is answered within this
  PartOrder order = PartOrder::BestScore;
  int label = 0;              // LabelOnly: the label served
};

// What a reply carries for a part (protocol/robot_frames.hpp): the pose in the robot's
// user frame, or the offset from the job's reference in the dialect's convention.
struct RobotDelivery {
  protocol::Dialect dialect = protocol::Dialect::Ur;
  protocol::RobotFrame frame;  // default: poses in the base frame
};

class ResultStore {
 public:
  ResultStore(boost::asio::io_context& io, std::set<int> knownJobs);
  ~ResultStore();
  ResultStore(const ResultStore&) = delete;
  ResultStore& operator=(const ResultStore&) = delete;

  // Registers a robot (by endpoint name). A robot never registered gets the default policy.
  void addRobot(const std::string& robot, RobotPolicy policy, RobotDelivery delivery = {});
  // What TRIG calls (on the I/O thread; must not block): the new cycle id, 0 when refused.
  // `flange`: an eye-in-hand snapshot's T_base_flange (TRIG,<job>,<pose>), else empty.
  // Without one, TRIG is answered -1 UNKNOWN_COMMAND.
  using TriggerFn = std::function<std::uint32_t(int jobId, const std::optional<Pose>& flange)>;
  void setTrigger(TriggerFn trigger) { trigger_ = std::move(trigger); }

  void onCycleStarted(std::uint32_t cycleId, int jobId);
  void onResult(const CycleResult& result);
  // Answers GET and JOB requests (the RequestHandler of every RobotServer).
  void handle(const std::string& robot, const protocol::RobotRequest& req, protocol::ReplyFn reply);

  // The replies one result turns into for a policy, in serving order (at least one).
  static std::vector<protocol::RobotReply> replies(const CycleResult& r, const RobotPolicy& policy,
                                                   const RobotDelivery& delivery = {});
  // The robot's current job (for tests and logs).
  int currentJob(const std::string& robot) const;

 private:
  struct Waiter;
  struct Progress {
    std::uint32_t cycleId = 0;  // the result the robot is being served from
    std::size_t next = 0;       // index of the next reply in replies(result, policy)
    std::optional<protocol::RobotReply> last;  // what the robot got last from it
    std::set<std::size_t> returned;  // indices handed out but not delivered: served first
  };
  using Sender = std::function<void(const protocol::RobotReply&, protocol::WrittenFn)>;
  struct RobotState {
    RobotPolicy policy;
    RobotDelivery delivery;
    int currentJob = 0;
    std::map<int, Progress> progress;  // per job
  };

  RobotState& state(const std::string& robot);
  // Serves the next undelivered reply of `job` to `robot`; false when there is none.
  bool serveNext(const std::string& robot, int job, const Sender& send);
  void answer(Waiter& w, const protocol::RobotReply& reply, protocol::WrittenFn written = {});
  // What a handed-out reply does once its fate is known: a reply that did not reach the
  // robot goes back into its progress, and a waiting request of the robot is served.
  protocol::WrittenFn onWritten(const std::string& robot, int job, std::uint32_t cycleId, std::size_t index);
  void serveWaiting(const std::string& robot, int job);

  // Parks a request until a result of `job` (cycle 0: any; else that cycle) or the deadline.
  void wait(const std::string& robot, int job, std::uint32_t cycle, protocol::ReplyFn reply, int deadlineMs);

  boost::asio::io_context& io_;
  TriggerFn trigger_;
  std::set<int> knownJobs_;
  std::map<int, CycleResult> latest_;  // per job
  std::map<std::string, RobotState> robots_;
  std::optional<std::uint32_t> running_;  // cycle in progress
  std::map<std::uint64_t, std::shared_ptr<Waiter>> waiters_;  // by arrival order
  std::uint64_t nextWaiter_ = 1;
  std::shared_ptr<char> alive_ = std::make_shared<char>();  // WrittenFns check it (they may outlive us)
};

}  // namespace vgr::daemon
