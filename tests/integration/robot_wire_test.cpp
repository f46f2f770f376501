// Every robot dialect on the wire: real RobotServers fed by the daemon's real ResultStore
// on one I/O thread (as in vgrd), raw TCP clients on loopback checking the exact bytes.
// fanuc and binary request/reply, JOB switching over the socket, multi-part serving, and
// the strict dialect's paper-002 exchange with each way it can go wrong.
#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>
#include <vector>

#include <boost/asio/io_context.hpp>

#include "daemon/result_store.hpp"
#include "protocol/robot_server.hpp"
#include "tests/support/io_thread.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace vgr::protocol {
namespace {

namespace asio = boost::asio;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
using daemon::PartOrder;
using daemon::ResultStore;
using daemon::RobotPolicy;

constexpr double kPi = 3.14159265358979323846;

// The robots' clients here read with a 3 s deadline.
class RawClient : public test::RawTcpClient {
 public:
  explicit RawClient(std::uint16_t port) : RawTcpClient(port, {.readTimeout = 3000ms}) {}
  // Exactly n bytes, or what came before the timeout / close.
  std::string readExactly(std::size_t n) { return readBytes(n); }
};

PartResult part(double x, double y, double rzDeg, double score, int label) {
  PartResult p;
  p.pose = poseFromXyzRz(x, y, 35.0, rzDeg * kPi / 180.0);
  p.score = score;
  p.label = label;
  return p;
}

class robot_wire : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = std::make_unique<ResultStore>(io_, std::set<int>{1, 2});
    ioThread_.start();
  }
  void TearDown() override {
    onIo([this] {
      for (auto& s : servers_) s->stop();
    });
    ioThread_.stop();
    servers_.clear();
    store_.reset();
  }
  void onIo(const std::function<void()>& f) { ioThread_.run(f); }

  std::uint16_t serve(RobotEndpoint ep, RobotPolicy policy = RobotPolicy{1, 300, PartOrder::BestScore, 0}) {
    std::uint16_t port = 0;
    onIo([&] {
      store_->addRobot(ep.name, policy);
      auto s = std::make_unique<RobotServer>(
          io_, ep, [this](const std::string& robot, const RobotRequest& req, ReplyFn reply) {
            store_->handle(robot, req, std::move(reply));
          });
      s->onStrictOutcome([this](const std::string& robot, const StrictOutcome& o) {
        std::lock_guard lock(mu_);
        outcomes_.push_back({robot, o});
      });
      if (s->start()) port = s->port();
      servers_.push_back(std::move(s));
    });
    return port;
  }

  void publish(const CycleResult& r) {
    onIo([&] {
      store_->onCycleStarted(r.cycleId, r.jobId);
      store_->onResult(r);
    });
  }
  CycleResult result(std::uint32_t id, int job, std::vector<PartResult> parts) {
    CycleResult r;
    r.cycleId = id;
    r.jobId = job;
    r.status = Status::Ok;
    r.parts = std::move(parts);
    return r;
  }

  std::vector<std::pair<std::string, StrictOutcome>> outcomes() {
    std::lock_guard lock(mu_);
    return outcomes_;
  }
  bool waitOutcomes(std::size_t n, std::chrono::milliseconds timeout = 3000ms) {
    const auto deadline = Clock::now() + timeout;
    while (Clock::now() < deadline) {
      if (outcomes().size() >= n) return true;
      std::this_thread::sleep_for(5ms);
    }
    return false;
  }

  static RobotEndpoint endpoint(const std::string& name, Dialect d) {
    RobotEndpoint ep;
    ep.name = name;
    ep.dialect = d;
    return ep;
  }

  vgr::test::IoThread ioThread_;
  asio::io_context& io_ = ioThread_.io();
  std::unique_ptr<ResultStore> store_;
  std::vector<std::unique_ptr<RobotServer>> servers_;
  std::mutex mu_;
  std::vector<std::pair<std::string, StrictOutcome>> outcomes_;
};

// ---- fanuc -------------------------------------------------------------------------------

TEST_F(robot_wire, FanucExactBytesFixedColumns) {
  const std::uint16_t port = serve(endpoint("m20", Dialect::Fanuc));
  ASSERT_NE(port, 0);
  publish(result(4711, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
  RawClient c(port);
  ASSERT_TRUE(c.send("GET,1\n"));  // KAREL: WRITE sock('GET,1', CR) works as well
  const std::string reply = c.readExactly(kFanucReplyChars);
  EXPECT_EQ(reply, "+0000,0004711,+00512.300,-00120.050,+00035.000,+000.000,+000.000,-012.500\r\n");
  EXPECT_LT(reply.size(), kFanucMaxReplyChars);
  // Nothing new: after the 300 ms deadline, 3 NO_NEW_TRIGGER in the same columns.
  ASSERT_TRUE(c.send("GET\r"));
  EXPECT_EQ(c.readExactly(kFanucReplyChars),
            "+0003,0000000,+00000.000,+00000.000,+00000.000,+000.000,+000.000,+000.000\r\n");
  ASSERT_TRUE(c.send("GET,1,LAST\r"));
  EXPECT_EQ(c.readExactly(kFanucReplyChars), reply);
  ASSERT_TRUE(c.send("HELLO\r"));
  EXPECT_EQ(c.readExactly(kFanucReplyChars),
            "-0001,0000000,+00000.000,+00000.000,+00000.000,+000.000,+000.000,+000.000\r\n");
  EXPECT_TRUE(c.quiet());
}

// ---- binary ------------------------------------------------------------------------------

TEST_F(robot_wire, BinaryExactFrames) {
  const std::uint16_t port = serve(endpoint("urcap", Dialect::Binary));
  publish(result(4711, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
  RawClient c(port);
  ASSERT_TRUE(c.send(binary::encodeRequest(binary::kCmdGet, 1)));
  const std::string f = c.readExactly(binary::kReplyBytes);
  const std::string expected(
      "\x56\x47\x52\x41\x00\x00\x00\x28\x00\x00\x00\x00\x00\x00\x12\x67\x00\x07\xd1\x2c\xff\xfe\x2b\x0e"
      "\x00\x00\x88\xb8\x00\x00\x00\x00\x00\x00\x00\x00\xff\xff\xcf\x2c",
      40);
  EXPECT_EQ(f, expected);
  // Garbage, then a frame: one error frame (-1), then the answer; in order.
  ASSERT_TRUE(c.send(std::string("hello world") + binary::encodeRequest(binary::kCmdGetLast, 1)));
  const std::string err = c.readExactly(binary::kReplyBytes);
  EXPECT_EQ(binary::readInt32(err, 0), static_cast<std::int32_t>(binary::kReplyMagic));
  EXPECT_EQ(binary::readInt32(err, 8), -1);
  EXPECT_EQ(c.readExactly(binary::kReplyBytes), expected);
  // Job switch to an unknown job: -7.
  ASSERT_TRUE(c.send(binary::encodeRequest(binary::kCmdJob, 99)));
  EXPECT_EQ(binary::readInt32(c.readExactly(binary::kReplyBytes), 8), -7);
  EXPECT_TRUE(c.quiet());
}

// ---- ur / abb: job switching and several parts -----------------------------------------

TEST_F(robot_wire, JobSwitchingOverTheSocket) {
  const std::uint16_t port = serve(endpoint("irb", Dialect::Abb));
  publish(result(50, 2, {part(100, 0, 0, 0.9, 0)}));
  RawClient c(port);
  ASSERT_TRUE(c.send("JOB,2#"));
  EXPECT_EQ(c.readExactly(std::string("0,0,0.000,0.000,0.000,0.000,0.000,0.000").size()), "0,0,0.000,0.000,0.000,0.000,0.000,0.000");
  ASSERT_TRUE(c.send("GET#"));  // the current job, now 2
  EXPECT_EQ(c.readExactly(std::string("0,50,100.000,0.000,35.000,0.000,0.000,0.000").size()), "0,50,100.000,0.000,35.000,0.000,0.000,0.000");
  ASSERT_TRUE(c.send("JOB,7#"));
  EXPECT_EQ(c.readExactly(std::string("-7,0,0.000,0.000,0.000,0.000,0.000,0.000").size()), "-7,0,0.000,0.000,0.000,0.000,0.000,0.000");
  EXPECT_TRUE(c.quiet());
  // The switch belongs to the robot, not the connection: a reconnect keeps job 2.
  c.close();
  publish(result(51, 2, {part(200, 0, 0, 0.9, 0)}));
  RawClient again(port);
  ASSERT_TRUE(again.send("GET#"));
  EXPECT_EQ(again.readExactly(std::string("0,51,200.000,0.000,35.000,0.000,0.000,0.000").size()), "0,51,200.000,0.000,35.000,0.000,0.000,0.000");
}

TEST_F(robot_wire, SeveralPartsOnePerRequestByLabel) {
  const std::uint16_t port = serve(endpoint("ur5", Dialect::Ur), RobotPolicy{1, 200, PartOrder::ByLabel, 0});
  publish(result(60, 1, {part(1, 0, 0, 0.99, 2), part(2, 0, 0, 0.9, 1), part(3, 0, 0, 0.8, 2)}));
  RawClient c(port);
  std::vector<std::string> got;
  for (int i = 0; i < 4; ++i) {
    ASSERT_TRUE(c.send("GET,1\n"));
    got.push_back(c.readExactly(66));
  }
  EXPECT_EQ(got[0], "(0,60,0.002000,0.000000,0.035000,0.000000,0.000000,0.000000)");  // label 1
  EXPECT_EQ(got[1], "(0,60,0.001000,0.000000,0.035000,0.000000,0.000000,0.000000)");  // label 2, best
  EXPECT_EQ(got[2], "(0,60,0.003000,0.000000,0.035000,0.000000,0.000000,0.000000)");
  EXPECT_EQ(got[3].substr(0, 5), "(3,0,");  // all served: NO_NEW_TRIGGER after the deadline
}

// ---- strict (paper 002) ----------------------------------------------------------------

class robot_strict_wire : public robot_wire {
 protected:
  std::uint16_t strictServer(int stepTimeoutMs = 300) {
    RobotEndpoint ep = endpoint("ur5-strict", Dialect::Strict);
    ep.stepTimeoutMs = stepTimeoutMs;
    return serve(ep, RobotPolicy{1, 200, PartOrder::BestScore, 0});
  }
  static constexpr const char* kFrame = "(0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)";
};

TEST_F(robot_strict_wire, PaperTokenSequence) {
  const std::uint16_t port = strictServer();
  RawClient robot(port);
  EXPECT_TRUE(robot.quiet(300ms));  // nothing to move yet: vgrd stays silent
  publish(result(70, 1, {part(512.3, -120.05, -12.5, 0.9, 0), part(100, 0, 0, 0.8, 0)}));
  EXPECT_EQ(robot.readExactly(10), "MoveJ_pose");
  ASSERT_TRUE(robot.send("MoveJ_pose_wait_pos"));
  EXPECT_EQ(robot.readExactly(std::string(kFrame).size()), kFrame);
  EXPECT_TRUE(robot.quiet(50ms));  // waits for the move
  ASSERT_TRUE(robot.send("MoveJ_pose_done"));
  // The second part of the same image follows at once.
  EXPECT_EQ(robot.readExactly(10), "MoveJ_pose");
  ASSERT_TRUE(robot.send("MoveJ_pose_wait_pos\n"));
  EXPECT_EQ(robot.readExactly(std::string("(0.100000,0.000000,0.035000,0.000000,0.000000,0.000000)").size()), "(0.100000,0.000000,0.035000,0.000000,0.000000,0.000000)");
  ASSERT_TRUE(robot.send("MoveJ_pose_done\n"));
  ASSERT_TRUE(waitOutcomes(2));
  for (const auto& [name, o] : outcomes()) {
    EXPECT_EQ(name, "ur5-strict");
    EXPECT_EQ(o.status, Status::Ok);
    EXPECT_EQ(o.cycleId, 70u);
  }
  EXPECT_TRUE(robot.quiet(300ms));  // everything delivered
}

TEST_F(robot_strict_wire, WrongTokenAbortsAndTheDaemonKeepsServing) {
  const std::uint16_t port = strictServer();
  {
    RawClient robot(port);
    publish(result(80, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
    EXPECT_EQ(robot.readExactly(10), "MoveJ_pose");
    ASSERT_TRUE(robot.send("MoveJ_pose_error\n"));
    EXPECT_TRUE(robot.waitClosed());
  }
  ASSERT_TRUE(waitOutcomes(1));
  EXPECT_EQ(outcomes()[0].second.status, Status::UnknownCommand);
  EXPECT_EQ(outcomes()[0].second.detail, "expected 'MoveJ_pose_wait_pos', got 'MoveJ_pose_error'");
  EXPECT_EQ(outcomes()[0].second.cycleId, 80u);

  // Wrong token at the second step.
  {
    RawClient robot(port);
    publish(result(81, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
    EXPECT_EQ(robot.readExactly(10), "MoveJ_pose");
    ASSERT_TRUE(robot.send("MoveJ_pose_wait_pos"));
    EXPECT_EQ(robot.readExactly(std::string(kFrame).size()), kFrame);
    ASSERT_TRUE(robot.send("MoveJ_pose_wait_pos"));
    EXPECT_TRUE(robot.waitClosed());
  }
  ASSERT_TRUE(waitOutcomes(2));
  EXPECT_EQ(outcomes()[1].second.status, Status::UnknownCommand);

  // A fresh connection is served normally.
  RawClient robot(port);
  publish(result(82, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
  EXPECT_EQ(robot.readExactly(10), "MoveJ_pose");
  ASSERT_TRUE(robot.send("MoveJ_pose_wait_pos"));
  EXPECT_EQ(robot.readExactly(std::string(kFrame).size()), kFrame);
  ASSERT_TRUE(robot.send("MoveJ_pose_done"));
  ASSERT_TRUE(waitOutcomes(3));
  EXPECT_EQ(outcomes()[2].second.status, Status::Ok);
  EXPECT_EQ(outcomes()[2].second.cycleId, 82u);
}

TEST_F(robot_strict_wire, SilenceAbortsAfterTheStepTimeout) {
  const std::uint16_t port = strictServer(300);
  RawClient robot(port);
  publish(result(90, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
  EXPECT_EQ(robot.readExactly(10), "MoveJ_pose");
  const auto t0 = Clock::now();
  EXPECT_TRUE(robot.waitClosed());  // nothing sent: closed after the step timeout
  const auto waited = Clock::now() - t0;
  EXPECT_GE(waited, 280ms);
  EXPECT_LT(waited, 1000ms);
  ASSERT_TRUE(waitOutcomes(1));
  EXPECT_EQ(outcomes()[0].second.status, Status::ProcessingTimeout);
  EXPECT_EQ(outcomes()[0].second.detail, "no 'MoveJ_pose_wait_pos' within the step timeout");

  // Silence at the second step too.
  RawClient second(port);
  publish(result(91, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
  EXPECT_EQ(second.readExactly(10), "MoveJ_pose");
  ASSERT_TRUE(second.send("MoveJ_pose_wait_pos"));
  EXPECT_EQ(second.readExactly(std::string(kFrame).size()), kFrame);
  EXPECT_TRUE(second.waitClosed());
  ASSERT_TRUE(waitOutcomes(2));
  EXPECT_EQ(outcomes()[1].second.detail, "no 'MoveJ_pose_done' within the step timeout");
}

TEST_F(robot_strict_wire, DisconnectMidExchange) {
  const std::uint16_t port = strictServer(2000);
  {
    RawClient robot(port);
    publish(result(95, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
    EXPECT_EQ(robot.readExactly(10), "MoveJ_pose");
    ASSERT_TRUE(robot.send("MoveJ_pose_wait_pos"));
    EXPECT_EQ(robot.readExactly(std::string(kFrame).size()), kFrame);
  }  // the robot's program stops here
  ASSERT_TRUE(waitOutcomes(1, 1000ms));  // reported at once, not after the 2 s step timeout
  EXPECT_EQ(outcomes()[0].second.status, Status::Internal);
  EXPECT_EQ(outcomes()[0].second.detail, "connection lost while waiting for 'MoveJ_pose_done'");

  RawClient robot(port);
  publish(result(96, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
  EXPECT_EQ(robot.readExactly(10), "MoveJ_pose");
}

TEST_F(robot_strict_wire, ConfiguredTokensAndLineEnd) {
  RobotEndpoint ep = endpoint("ur5-pick", Dialect::Strict);
  ep.strict = StrictTokens{"Pick_pose", "Pick_ready", "Pick_done", "\n", "", "MoveJ_none"};
  ep.stepTimeoutMs = 500;
  const std::uint16_t port = serve(ep, RobotPolicy{1, 200, PartOrder::BestScore, 0});
  RawClient robot(port);
  publish(result(97, 1, {part(512.3, -120.05, -12.5, 0.9, 0)}));
  EXPECT_EQ(robot.readExactly(10), "Pick_pose\n");
  ASSERT_TRUE(robot.send("Pick_ready\n"));
  EXPECT_EQ(robot.readExactly(std::string(kFrame).size() + 1), std::string(kFrame) + "\n");
  ASSERT_TRUE(robot.send("Pick_done\n"));
  ASSERT_TRUE(waitOutcomes(1));
  EXPECT_EQ(outcomes()[0].second.status, Status::Ok);
}

}  // namespace
}  // namespace vgr::protocol
