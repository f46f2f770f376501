#include "daemon/result_store.hpp"

#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>

namespace vgr::daemon {

struct ResultStore::Waiter {
  std::string robot;
  int job = 0;
  protocol::ReplyFn reply;
  boost::asio::steady_timer timer;
  bool done = false;
  explicit Waiter(boost::asio::io_context& io) : timer(io) {}
};

ResultStore::ResultStore(boost::asio::io_context& io, std::set<int> knownJobs) : io_(io), knownJobs_(std::move(knownJobs)) {}

ResultStore::~ResultStore() {
  for (auto& [id, w] : waiters_) w->timer.cancel();
}

protocol::RobotReply ResultStore::toReply(const CycleResult& r) {
  protocol::RobotReply reply;
  reply.status = r.status;
  reply.cycleId = r.cycleId;
  if (r.status == Status::Ok && !r.parts.empty()) reply.pose = r.parts.front().pose;
  return reply;
}

void ResultStore::answer(Waiter& w, const protocol::RobotReply& reply) {
  if (w.done) return;
  w.done = true;
  w.timer.cancel();
  w.reply(reply);
}

void ResultStore::onCycleStarted(std::uint32_t cycleId, int /*jobId*/) { running_ = cycleId; }

void ResultStore::onResult(const CycleResult& r) {
  if (running_ == r.cycleId) running_.reset();
  latest_[r.jobId] = r;
  const protocol::RobotReply reply = toReply(r);
  for (auto it = waiters_.begin(); it != waiters_.end();) {
    Waiter& w = *it->second;
    if (w.job == r.jobId) {
      delivered_[w.robot] = r.cycleId;
      answer(w, reply);
      it = waiters_.erase(it);
    } else {
      ++it;
    }
  }
}

void ResultStore::handleGet(const std::string& robot, const protocol::RobotRequest& req, protocol::ReplyFn reply,
                            int deadlineMs) {
  if (!knownJobs_.count(req.job)) {
    protocol::RobotReply r;
    r.status = Status::JobNotFound;
    reply(r);
    return;
  }
  auto it = latest_.find(req.job);
  if (it != latest_.end()) {
    auto d = delivered_.find(robot);
    const bool fresh = d == delivered_.end() || d->second != it->second.cycleId;
    if (fresh || req.last) {
      delivered_[robot] = it->second.cycleId;
      reply(toReply(it->second));
      return;
    }
  } else if (req.last && !running_) {
    protocol::RobotReply r;
    r.status = Status::NoNewTrigger;
    reply(r);
    return;
  }

  // Wait for the next result of this job, at most until the robot's deadline.
  auto w = std::make_shared<Waiter>(io_);
  w->robot = robot;
  w->job = req.job;
  w->reply = std::move(reply);
  const std::uint64_t id = nextWaiter_++;
  waiters_[id] = w;
  w->timer.expires_after(std::chrono::milliseconds(deadlineMs));
  w->timer.async_wait([this, id, w](const boost::system::error_code& ec) {
    if (ec || w->done) return;
    protocol::RobotReply r;
    r.status = running_ ? Status::ResultNotReady : Status::NoNewTrigger;
    answer(*w, r);
    waiters_.erase(id);
  });
}

}  // namespace vgr::daemon
