// TRIG: a robot asks for a part with no PLC in the loop (docs/protocols.md). The codec
// parses "TRIG" / "TRIG,<job>" and binary command 4; the ResultStore triggers a cycle
// through its trigger function and answers with THAT cycle's result, -3 when the queue
// refuses, 2 RESULT_NOT_READY at the deadline, -1 when vgrd gave it no trigger function.
#include <gtest/gtest.h>

#include <chrono>
#include <optional>

#include <boost/asio/io_context.hpp>

#include "daemon/result_store.hpp"
#include "protocol/robot_codec.hpp"

namespace vgr::daemon {
namespace {

using namespace std::chrono_literals;
using protocol::Command;
using protocol::RobotReply;
using protocol::RobotRequest;

TEST(robot_trigger, parses_text_and_binary) {
  auto r = protocol::parseRequest("TRIG");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->command, Command::Trigger);
  EXPECT_EQ(r->job, 0);
  r = protocol::parseRequest("TRIG,12");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->command, Command::Trigger);
  EXPECT_EQ(r->job, 12);
  for (const char* bad : {"TRIG,0", "TRIG,x", "TRIG,1,LAST", "TRIG,"}) {
    const auto e = protocol::parseRequest(bad);
    ASSERT_FALSE(e) << bad;
    EXPECT_EQ(e.error().code, Status::BadArgument) << bad;
  }
  EXPECT_EQ(protocol::parseRequest("trig,1").error().code, Status::UnknownCommand);

  protocol::RequestDecoder d(protocol::Dialect::Binary);
  d.append(protocol::binary::encodeRequest(protocol::binary::kCmdTrigger, 3));
  d.append(protocol::binary::encodeRequest(protocol::binary::kCmdTrigger, 0));
  auto a = d.next();
  ASSERT_TRUE(a && *a);
  EXPECT_EQ((*a)->command, Command::Trigger);
  EXPECT_EQ((*a)->job, 3);
  auto b = d.next();
  ASSERT_TRUE(b && *b);
  EXPECT_EQ((*b)->job, 0);
}

class robot_trigger_store : public ::testing::Test {
 protected:
  robot_trigger_store() : store_(io_, {1, 2}) { store_.addRobot("ur", RobotPolicy{1, 200, PartOrder::BestScore, 0}); }

  std::optional<RobotReply> run(std::optional<RobotReply>& got, std::chrono::milliseconds wait) {
    const auto until = std::chrono::steady_clock::now() + wait;
    while (!got && std::chrono::steady_clock::now() < until) {
      io_.restart();
      io_.run_for(5ms);
    }
    return got;
  }

  static CycleResult result(std::uint32_t id, int job, double x) {
    CycleResult r;
    r.cycleId = id;
    r.jobId = job;
    r.status = Status::Ok;
    PartResult p;
    p.pose = poseFromXyzRz(x, 0, 0, 0);
    r.parts = {p};
    return r;
  }

  boost::asio::io_context io_;
  ResultStore store_;
};

TEST_F(robot_trigger_store, answers_with_the_triggered_cycle) {
  std::vector<int> triggered;
  store_.setTrigger([&](int job, const std::optional<Pose>&) {
    triggered.push_back(job);
    return 42u;
  });
  std::optional<RobotReply> got;
  store_.handle("ur", RobotRequest{Command::Trigger, 0, false, std::nullopt}, [&](const RobotReply& r) { got = r; });
  ASSERT_EQ(triggered, std::vector<int>{1});  // the robot's current job
  store_.onResult(result(41, 1, 10));         // an older cycle of the same job: not this one
  run(got, 20ms);
  EXPECT_FALSE(got);
  store_.onResult(result(42, 1, 20));
  ASSERT_TRUE(run(got, 100ms));
  EXPECT_EQ(got->status, Status::Ok);
  EXPECT_EQ(got->cycleId, 42u);
  EXPECT_DOUBLE_EQ(got->pose.x, 20);
}

TEST_F(robot_trigger_store, refused_late_and_unavailable) {
  std::optional<RobotReply> got;
  store_.handle("ur", RobotRequest{Command::Trigger, 2, false, std::nullopt}, [&](const RobotReply& r) { got = r; });
  ASSERT_TRUE(got);
  EXPECT_EQ(got->status, Status::UnknownCommand);

  store_.setTrigger([](int, const std::optional<Pose>&) { return 0u; });
  got.reset();
  store_.handle("ur", RobotRequest{Command::Trigger, 2, false, std::nullopt}, [&](const RobotReply& r) { got = r; });
  ASSERT_TRUE(got);
  EXPECT_EQ(got->status, Status::BusyOverrun);

  store_.setTrigger([](int, const std::optional<Pose>&) { return 7u; });
  got.reset();
  store_.handle("ur", RobotRequest{Command::Trigger, 2, false, std::nullopt}, [&](const RobotReply& r) { got = r; });
  ASSERT_TRUE(run(got, 1000ms));
  EXPECT_EQ(got->status, Status::ResultNotReady);
}

}  // namespace
}  // namespace vgr::daemon
