#include "daemon/result_store.hpp"

#include <algorithm>
#include <chrono>
#include <random>

#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>
#include <boost/asio/steady_timer.hpp>

#include "core/log.hpp"

namespace vgr::daemon {

struct ResultStore::Waiter {
  std::string robot;
  int job = 0;
  std::uint32_t cycle = 0;  // 0: the next result of the job; else only this cycle's (TRIG)
  protocol::ReplyFn reply;
  boost::asio::steady_timer timer;
  bool done = false;
  explicit Waiter(boost::asio::io_context& io) : timer(io) {}
};

ResultStore::ResultStore(boost::asio::io_context& io, std::set<int> knownJobs)
    : io_(io), knownJobs_(std::move(knownJobs)) {}

ResultStore::~ResultStore() {
  for (auto& [id, w] : waiters_) w->timer.cancel();
}

void ResultStore::addRobot(const std::string& robot, RobotPolicy policy, RobotDelivery delivery) {
  RobotState& s = robots_[robot];
  s.policy = policy;
  s.delivery = delivery;
  s.currentJob = policy.job != 0 ? policy.job : (knownJobs_.empty() ? 0 : *knownJobs_.begin());
}

ResultStore::RobotState& ResultStore::state(const std::string& robot) {
  auto it = robots_.find(robot);
  if (it == robots_.end()) {
    addRobot(robot, RobotPolicy{});
    it = robots_.find(robot);
  }
  return it->second;
}

int ResultStore::currentJob(const std::string& robot) const {
  auto it = robots_.find(robot);
  if (it != robots_.end()) return it->second.currentJob;
  return knownJobs_.empty() ? 0 : *knownJobs_.begin();
}

std::vector<protocol::RobotReply> ResultStore::replies(const CycleResult& r, const RobotPolicy& policy,
                                                      const RobotDelivery& delivery) {
  std::vector<protocol::RobotReply> out;
  protocol::RobotReply base;
  base.cycleId = r.cycleId;
  base.status = r.status;
  if (r.status != Status::Ok) {
    out.push_back(base);
    return out;
  }
  // The locator's order is best first; stable sorts and filters keep it within a label.
  std::vector<const PartResult*> parts;
  for (const PartResult& p : r.parts) {
    if (policy.order == PartOrder::LabelOnly && p.label != policy.label) continue;
    parts.push_back(&p);
  }
  if (policy.order == PartOrder::ByLabel)
    std::stable_sort(parts.begin(), parts.end(), [](const PartResult* a, const PartResult* b) { return a->label < b->label; });
  if (policy.order == PartOrder::Random) {
    // Paper 002's random selection: any of the parts first. Drawn from the cycle id, so that
    // every call for one result (this function runs on each GET) gives the same order.
    std::mt19937 rng(r.cycleId * 2654435761u + 12345u);
    std::shuffle(parts.begin(), parts.end(), rng);
  }
  if (parts.empty()) {
    base.status = Status::NoPartFound;
    out.push_back(base);
    return out;
  }
  for (const PartResult* p : parts) {
    protocol::RobotReply reply = base;
    reply.pose = protocol::deliveredPose(delivery.dialect, delivery.frame, r.reference, p->pose);
    reply.label = p->label;
    reply.confidence = p->confidence;
    out.push_back(reply);
  }
  return out;
}

void ResultStore::answer(Waiter& w, const protocol::RobotReply& reply, protocol::WrittenFn written) {
  if (w.done) {
    if (written) written(false);
    return;
  }
  w.done = true;
  w.timer.cancel();
  w.reply(reply, std::move(written));
}

bool ResultStore::serveNext(const std::string& robot, int job, const Sender& send) {
  auto it = latest_.find(job);
  if (it == latest_.end()) return false;
  RobotState& s = state(robot);
  Progress& p = s.progress[job];
  if (p.cycleId != it->second.cycleId) p = Progress{it->second.cycleId, 0, std::nullopt, {}};
  const std::vector<protocol::RobotReply> all = replies(it->second, s.policy, s.delivery);
  std::size_t index = 0;
  if (!p.returned.empty()) {
    index = *p.returned.begin();
    p.returned.erase(p.returned.begin());
  } else if (p.next < all.size()) {
    index = p.next++;
  } else {
    return false;
  }
  p.last = all[index];
  send(*p.last, onWritten(robot, job, p.cycleId, index));
  return true;
}

protocol::WrittenFn ResultStore::onWritten(const std::string& robot, int job, std::uint32_t cycleId, std::size_t index) {
  // May run inside send() (a connection already closed answers at once): only the
  // progress is touched here; waiting requests are served from a posted handler.
  return [this, alive = std::weak_ptr<char>(alive_), robot, job, cycleId, index](bool written) {
    if (written || alive.expired()) return;
    auto it = robots_.find(robot);
    if (it == robots_.end()) return;
    Progress& p = it->second.progress[job];
    if (p.cycleId != cycleId) return;  // a newer result of the job replaced it
    p.returned.insert(index);
    log::info("robot", "robot '{}': reply of cycle {} (part {}) did not reach the robot; it is served again", robot,
              cycleId, index + 1);
    boost::asio::post(io_, [this, alive, robot, job] {
      if (!alive.expired()) serveWaiting(robot, job);
    });
  };
}

void ResultStore::serveWaiting(const std::string& robot, int job) {
  for (auto it = waiters_.begin(); it != waiters_.end();) {
    Waiter& w = *it->second;
    if (w.done || w.robot != robot || w.job != job) {
      ++it;
      continue;
    }
    auto res = latest_.find(job);
    if (res == latest_.end() || (w.cycle != 0 && w.cycle != res->second.cycleId)) {
      ++it;
      continue;
    }
    bool served = false;
    serveNext(robot, job, [&](const protocol::RobotReply& reply, protocol::WrittenFn written) {
      served = true;
      answer(w, reply, std::move(written));
    });
    if (!served) return;
    it = waiters_.erase(it);
  }
}

void ResultStore::onCycleStarted(std::uint32_t cycleId, int /*jobId*/) { running_ = cycleId; }

void ResultStore::onResult(const CycleResult& r) {
  if (running_ == r.cycleId) running_.reset();
  latest_[r.jobId] = r;
  // A result wakes the requests waiting for its job, oldest first, those that asked for
  // exactly this cycle (TRIG) before the others: each takes its robot's next part. A part
  // goes to ONE connection of a robot (docs/protocols.md): when a robot has more waiting
  // connections than the result has parts, the extra ones go on waiting (for the next
  // result, or their deadline's 2/3), they do not get the same part again.
  for (const bool exact : {true, false}) {
    for (auto it = waiters_.begin(); it != waiters_.end();) {
      Waiter& w = *it->second;
      if (w.job != r.jobId || w.done || (w.cycle != 0 && w.cycle != r.cycleId) || (w.cycle != 0) != exact) {
        ++it;
        continue;
      }
      bool served = false;
      serveNext(w.robot, w.job, [&](const protocol::RobotReply& reply, protocol::WrittenFn written) {
        served = true;
        answer(w, reply, std::move(written));
      });
      if (!served) {
        ++it;
        continue;
      }
      it = waiters_.erase(it);
    }
  }
}

void ResultStore::handle(const std::string& robot, const protocol::RobotRequest& req, protocol::ReplyFn reply) {
  RobotState& s = state(robot);
  const int job = req.job != 0 ? req.job : s.currentJob;
  if (!knownJobs_.count(job)) {
    protocol::RobotReply r;
    r.status = Status::JobNotFound;
    reply(r);
    return;
  }

  if (req.command == protocol::Command::Job) {
    s.currentJob = job;
    reply(protocol::RobotReply{});  // 0 OK, cycle 0, zero pose
    return;
  }

  if (req.command == protocol::Command::Trigger) {
    protocol::RobotReply r;
    if (!trigger_) {
      r.status = Status::UnknownCommand;
      reply(r);
      return;
    }
    const std::uint32_t cycle = trigger_(job, req.flange);
    if (cycle == 0) {
      r.status = Status::BusyOverrun;
      reply(r);
      return;
    }
    wait(robot, job, cycle, std::move(reply), s.policy.replyDeadlineMs);
    return;
  }

  if (req.last) {
    auto it = latest_.find(job);
    if (it != latest_.end()) {
      Progress& p = s.progress[job];
      if (p.cycleId == it->second.cycleId && p.last) {
        reply(*p.last);
        return;
      }
      if (serveNext(robot, job, [&reply](const protocol::RobotReply& r, protocol::WrittenFn w) { reply(r, std::move(w)); })) return;
    } else if (!running_) {
      protocol::RobotReply r;
      r.status = Status::NoNewTrigger;
      reply(r);
      return;
    }
  } else if (serveNext(robot, job, [&reply](const protocol::RobotReply& r, protocol::WrittenFn w) { reply(r, std::move(w)); })) {
    return;
  }

  // Wait for the next result of this job, at most until the robot's deadline.
  wait(robot, job, 0, std::move(reply), s.policy.replyDeadlineMs);
}

void ResultStore::wait(const std::string& robot, int job, std::uint32_t cycle, protocol::ReplyFn reply, int deadlineMs) {
  auto w = std::make_shared<Waiter>(io_);
  w->robot = robot;
  w->job = job;
  w->cycle = cycle;
  w->reply = std::move(reply);
  const std::uint64_t id = nextWaiter_++;
  waiters_[id] = w;
  w->timer.expires_after(std::chrono::milliseconds(deadlineMs));
  w->timer.async_wait([this, id, w](const boost::system::error_code& ec) {
    if (ec || w->done) return;
    protocol::RobotReply r;
    // A triggered cycle is queued or running even before onCycleStarted has been seen.
    r.status = running_ || w->cycle != 0 ? Status::ResultNotReady : Status::NoNewTrigger;
    answer(*w, r);
    waiters_.erase(id);
  });
}

}  // namespace vgr::daemon
