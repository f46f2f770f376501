// GET semantics of PROTOCOLS.md on the daemon's ResultStore (daemon/result_store.hpp): a
// fresh result once per robot, LAST, waiting until the deadline (2 / 3), 1 NO_PART_FOUND,
// several parts one per request in each robot's order, and JOB switching. Runs the store
// on a local io_context, as vgrd's I/O thread does.
#include <gtest/gtest.h>

#include <chrono>
#include <optional>
#include <vector>

#include <boost/asio/io_context.hpp>

#include "daemon/result_store.hpp"

namespace vgr::daemon {
namespace {

using namespace std::chrono_literals;
using protocol::Command;
using protocol::RobotReply;
using protocol::RobotRequest;

PartResult part(double x, double score, int label) {
  PartResult p;
  p.pose = poseFromXyzRz(x, 0, 0, 0);
  p.score = score;
  p.label = label;
  return p;
}

CycleResult result(std::uint32_t id, int job, std::vector<PartResult> parts, Status status = Status::Ok) {
  CycleResult r;
  r.cycleId = id;
  r.jobId = job;
  r.status = status;
  r.parts = std::move(parts);
  return r;
}

RobotRequest get(int job = 0, bool last = false) { return RobotRequest{Command::Get, job, last, std::nullopt}; }

class robot_result_store : public ::testing::Test {
 protected:
  robot_result_store() : store_(io_, {1, 2}) {
    store_.addRobot("ur", RobotPolicy{1, 100, PartOrder::BestScore, 0});
    store_.addRobot("abb", RobotPolicy{1, 100, PartOrder::ByLabel, 0});
    store_.addRobot("fanuc", RobotPolicy{1, 100, PartOrder::LabelOnly, 3});
  }

  // Sends one request and runs the I/O loop until it is answered (or `wait` passes).
  std::optional<RobotReply> ask(const std::string& robot, RobotRequest req, std::chrono::milliseconds wait = 500ms) {
    std::optional<RobotReply> got;
    store_.handle(robot, req, [&](const RobotReply& r) { got = r; });
    const auto until = std::chrono::steady_clock::now() + wait;
    while (!got && std::chrono::steady_clock::now() < until) {
      io_.restart();
      io_.run_for(5ms);
    }
    return got;
  }

  boost::asio::io_context io_;
  ResultStore store_;
};

TEST_F(robot_result_store, FreshResultOncePerRobotThenNoNewTrigger) {
  store_.onCycleStarted(7, 1);
  store_.onResult(result(7, 1, {part(10, 0.9, 0)}));
  auto a = ask("ur", get(1));
  ASSERT_TRUE(a);
  EXPECT_EQ(a->status, Status::Ok);
  EXPECT_EQ(a->cycleId, 7u);
  EXPECT_DOUBLE_EQ(a->pose.x, 10);
  // Another robot still gets it once.
  auto b = ask("abb", get(1));
  ASSERT_TRUE(b);
  EXPECT_EQ(b->cycleId, 7u);
  // Again: nothing new; after the 100 ms deadline -> 3 NO_NEW_TRIGGER.
  const auto t0 = std::chrono::steady_clock::now();
  auto c = ask("ur", get(1));
  ASSERT_TRUE(c);
  EXPECT_EQ(c->status, Status::NoNewTrigger);
  EXPECT_EQ(c->cycleId, 0u);
  EXPECT_GE(std::chrono::steady_clock::now() - t0, 95ms);
}

TEST_F(robot_result_store, WaitsForTheNextResultAndReportsARunningCycle) {
  std::optional<RobotReply> got;
  store_.handle("ur", get(), [&](const RobotReply& r) { got = r; });
  io_.run_for(20ms);
  EXPECT_FALSE(got);
  store_.onCycleStarted(8, 1);
  store_.onResult(result(8, 1, {part(20, 0.9, 0)}));
  ASSERT_TRUE(got);  // answered at once, inside onResult
  EXPECT_EQ(got->cycleId, 8u);

  store_.onCycleStarted(9, 1);  // running past the deadline -> 2 RESULT_NOT_READY
  auto r = ask("ur", get());
  ASSERT_TRUE(r);
  EXPECT_EQ(r->status, Status::ResultNotReady);
}

TEST_F(robot_result_store, NoPartFoundAndErrorsOnce) {
  store_.onResult(result(3, 1, {}, Status::NoPartFound));
  auto a = ask("ur", get());
  ASSERT_TRUE(a);
  EXPECT_EQ(a->status, Status::NoPartFound);
  EXPECT_EQ(a->cycleId, 3u);
  EXPECT_EQ(ask("ur", get())->status, Status::NoNewTrigger);
  store_.onResult(result(4, 1, {}, Status::CameraError));
  EXPECT_EQ(ask("ur", get())->status, Status::CameraError);
  // An Ok result without parts is NO_PART_FOUND too.
  store_.onResult(result(5, 1, {}));
  EXPECT_EQ(ask("ur", get())->status, Status::NoPartFound);
}

TEST_F(robot_result_store, SeveralPartsOnePerRequestInEachRobotsOrder) {
  // Locator order = best score first.
  store_.onResult(result(11, 1, {part(1, 0.99, 3), part(2, 0.95, 1), part(3, 0.90, 2), part(4, 0.80, 1), part(5, 0.7, 3)}));
  std::vector<double> ur, abb, fanuc;
  for (int i = 0; i < 5; ++i) ur.push_back(ask("ur", get())->pose.x);
  for (int i = 0; i < 5; ++i) abb.push_back(ask("abb", get())->pose.x);
  for (int i = 0; i < 2; ++i) fanuc.push_back(ask("fanuc", get())->pose.x);
  EXPECT_EQ(ur, (std::vector<double>{1, 2, 3, 4, 5}));   // best score first
  EXPECT_EQ(abb, (std::vector<double>{2, 4, 3, 1, 5}));  // label 1, 2, 3; best first within
  EXPECT_EQ(fanuc, (std::vector<double>{1, 5}));         // label 3 only
  EXPECT_EQ(ask("ur", get())->status, Status::NoNewTrigger);
  EXPECT_EQ(ask("fanuc", get())->status, Status::NoNewTrigger);

  // label_only with no such label in the image: 1 NO_PART_FOUND, with the cycle id.
  store_.onResult(result(12, 1, {part(6, 0.9, 1)}));
  auto f = ask("fanuc", get());
  EXPECT_EQ(f->status, Status::NoPartFound);
  EXPECT_EQ(f->cycleId, 12u);
}

TEST_F(robot_result_store, LastRepeatsWhatTheRobotGotLast) {
  EXPECT_EQ(ask("ur", get(1, true))->status, Status::NoNewTrigger);  // nothing ever: at once
  store_.onResult(result(21, 1, {part(1, 0.9, 0), part(2, 0.8, 0)}));
  EXPECT_DOUBLE_EQ(ask("ur", get(1, true))->pose.x, 1);  // first part, now delivered
  EXPECT_DOUBLE_EQ(ask("ur", get(1))->pose.x, 2);
  EXPECT_DOUBLE_EQ(ask("ur", get(1, true))->pose.x, 2);
  EXPECT_DOUBLE_EQ(ask("ur", get(1, true))->pose.x, 2);
  EXPECT_EQ(ask("ur", get(1))->status, Status::NoNewTrigger);
}

TEST_F(robot_result_store, JobSwitching) {
  EXPECT_EQ(store_.currentJob("ur"), 1);
  store_.onResult(result(31, 2, {part(7, 0.9, 0)}));
  auto sw = ask("ur", RobotRequest{Command::Job, 2, false, std::nullopt});
  ASSERT_TRUE(sw);
  EXPECT_EQ(sw->status, Status::Ok);
  EXPECT_EQ(sw->cycleId, 0u);
  EXPECT_EQ(store_.currentJob("ur"), 2);
  EXPECT_DOUBLE_EQ(ask("ur", get())->pose.x, 7);  // GET = job 2 now
  EXPECT_EQ(ask("ur", RobotRequest{Command::Job, 9, false, std::nullopt})->status, Status::JobNotFound);
  EXPECT_EQ(store_.currentJob("ur"), 2);
  EXPECT_EQ(ask("ur", get(9))->status, Status::JobNotFound);
  EXPECT_EQ(store_.currentJob("abb"), 1);  // per robot
}

TEST_F(robot_result_store, EveryWaitingConnectionOfARobotIsAnswered) {
  // Two connections of one robot wait; the image has two parts: one each, in order.
  std::optional<RobotReply> a, b;
  store_.handle("ur", get(), [&](const RobotReply& r) { a = r; });
  store_.handle("ur", get(), [&](const RobotReply& r) { b = r; });
  store_.onResult(result(41, 1, {part(1, 0.9, 0), part(2, 0.8, 0)}));
  ASSERT_TRUE(a && b);
  EXPECT_DOUBLE_EQ(a->pose.x, 1);
  EXPECT_DOUBLE_EQ(b->pose.x, 2);
}

// Issue 19, item 4 (decided: a cycle's part goes to ONE connection of a robot, as
// docs/protocols.md says). Before, the second waiting connection got the same part of
// cycle 42 again: one cycle delivered to two connections of one endpoint.
TEST_F(robot_result_store, OnePartGoesToOneConnectionOfARobotTheOtherWaitsOn) {
  std::optional<RobotReply> a, b, c;
  store_.handle("ur", get(), [&](const RobotReply& r) { a = r; });
  store_.handle("ur", get(), [&](const RobotReply& r) { b = r; });
  store_.handle("abb", get(), [&](const RobotReply& r) { c = r; });
  store_.onResult(result(42, 1, {part(3, 0.9, 0)}));
  ASSERT_TRUE(a && c);
  EXPECT_EQ(a->cycleId, 42u);
  EXPECT_DOUBLE_EQ(a->pose.x, 3);
  EXPECT_EQ(c->cycleId, 42u) << "another robot gets its own copy";
  EXPECT_FALSE(b) << "the robot's second connection got cycle 42 too";
  // The waiting connection takes the next result, not the one its robot already got.
  store_.onResult(result(43, 1, {part(4, 0.9, 0)}));
  ASSERT_TRUE(b);
  EXPECT_EQ(b->cycleId, 43u);
  EXPECT_DOUBLE_EQ(b->pose.x, 4);
  // Still once per robot afterwards.
  EXPECT_EQ(ask("ur", get())->status, Status::NoNewTrigger);
}

TEST_F(robot_result_store, AnExtraWaitingConnectionEndsAtItsDeadlineWithoutARepeat) {
  std::optional<RobotReply> a, b;
  store_.handle("ur", get(), [&](const RobotReply& r) { a = r; });
  store_.handle("ur", get(), [&](const RobotReply& r) { b = r; });
  store_.onResult(result(44, 1, {part(5, 0.9, 0)}));
  ASSERT_TRUE(a);
  const auto until = std::chrono::steady_clock::now() + 500ms;
  while (!b && std::chrono::steady_clock::now() < until) {
    io_.restart();
    io_.run_for(5ms);
  }
  ASSERT_TRUE(b) << "answered by its 100 ms deadline";
  EXPECT_EQ(b->status, Status::NoNewTrigger);
  EXPECT_EQ(b->cycleId, 0u);
}

}  // namespace
}  // namespace vgr::daemon
