// A real RobotServer on ephemeral loopback ports, driven by raw POSIX client sockets that
// behave like robot programs (protocol/robot_server.hpp). One io_context thread, as in vgrd.
// Suite named robot_server so `ctest -R robot` finds it.
// GCC 12 reports a false -Wmaybe-uninitialized inside <regex>'s std::function members when
// built with -fsanitize (VGR_SANITIZE); it must not break -Werror there. Test code only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include "protocol/robot_server.hpp"

#include <unistd.h>

#include <gtest/gtest.h>

#include <atomic>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <functional>
#include <memory>
#include <optional>
#include <regex>
#include <stdexcept>
#include <string>
#include <thread>
#include <vector>

#include <fmt/core.h>
#include <boost/asio/io_context.hpp>
#include <boost/asio/steady_timer.hpp>
#include <nlohmann/json.hpp>

#include "tests/support/command.hpp"
#include "tests/support/io_thread.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace vgr::protocol {
namespace {

namespace asio = boost::asio;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;

const std::regex kUrRegex(R"(\(-?\d+,\d+(,-?\d+\.\d{6}){6}\))");
const std::regex kAbbRegex(R"(-?\d+,\d+(,-?\d+\.\d{3}){6})");

// The handler's pose: x=512.3 mm, y=-120.05 mm, z=35 mm, rz=-12.5 deg; cycle id = job.
// (fmt rather than operator+: GCC 12 -O3 emits a false -Wrestrict for short concatenations.)
std::string urOk(int cycle) {
  return fmt::format("(0,{},0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)", cycle);
}
std::string abbOk(int cycle) { return fmt::format("0,{},512.300,-120.050,35.000,-12.500,0.000,0.000", cycle); }
std::string urStatus(int status) {
  return fmt::format("({},0,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000)", status);
}
std::string abbStatus(int status) { return fmt::format("{},0,0.000,0.000,0.000,0.000,0.000,0.000", status); }

RobotEndpoint endpoint(std::string name, Dialect dialect, std::string bind, std::uint16_t port, std::size_t maxClients) {
  RobotEndpoint ep;
  ep.name = std::move(name);
  ep.dialect = dialect;
  ep.bind = std::move(bind);
  ep.port = port;
  ep.maxClients = maxClients;
  return ep;
}

using test::RawTcpClient;

class RobotServerFixture : public ::testing::Test {
 protected:
  void SetUp() override {
    ur_ = std::make_unique<RobotServer>(io_, endpoint("ur-cell1", Dialect::Ur, "127.0.0.1", 0, 8), handler());
    abb_ = std::make_unique<RobotServer>(io_, endpoint("abb-cell1", Dialect::Abb, "127.0.0.1", 0, 8), handler());
    ASSERT_TRUE(ur_->start());
    ASSERT_TRUE(abb_->start());
    ASSERT_NE(ur_->port(), 0);
    ASSERT_NE(abb_->port(), 0);
    ioThread_.start();
  }

  void TearDown() override {
    onIo([this] {
      for (auto& s : extra_) s->stop();
      ur_->stop();
      abb_->stop();
    });
    ioThread_.stop();
    extra_.clear();
    ur_.reset();
    abb_.reset();
  }

  // Runs f on the I/O thread and waits for it.
  void onIo(const std::function<void()>& f) { ioThread_.run(f); }

  std::size_t clients(RobotServer& s) {
    std::size_t n = 0;
    onIo([&] { n = s.clientCount(); });
    return n;
  }

  // job 1: immediate reply; 2: after a 50 ms timer; 3: drops the ReplyFn; 4: throws;
  // 5: replies twice; 6: NO_PART_FOUND; 7: after 300 ms. Cycle id = job.
  RequestHandler handler() {
    return [this](const std::string& robot, const RobotRequest& req, ReplyFn reply) {
      ++requests_;
      lastRobot_ = robot;
      RobotReply r;
      r.cycleId = static_cast<std::uint32_t>(req.job);
      r.pose = poseFromXyzRz(512.3, -120.05, 35.0, -12.5 * M_PI / 180.0);
      switch (req.job) {
        case 1:
          reply(r);
          break;
        case 2:
        case 7: {
          auto timer = std::make_shared<asio::steady_timer>(io_, req.job == 2 ? 50ms : 300ms);
          timer->async_wait([timer, reply, r](const boost::system::error_code&) { reply(r); });
          break;
        }
        case 3:
          break;
        case 4:
          throw std::runtime_error("handler failure (test)");
        case 5:
          reply(r);
          reply(r);
          break;
        case 6:
          r.status = Status::NoPartFound;
          reply(r);
          break;
        default:
          reply(r);
      }
    };
  }

  vgr::test::IoThread ioThread_;
  asio::io_context& io_ = ioThread_.io();
  std::unique_ptr<RobotServer> ur_, abb_;
  std::vector<std::unique_ptr<RobotServer>> extra_;
  std::atomic<int> requests_{0};
  std::string lastRobot_;  // written on the I/O thread, read after a reply arrived
};

using robot_server = RobotServerFixture;

TEST_F(robot_server, UrReplyIsExactlyTheParenthesisedValues) {
  RawTcpClient c(ur_->port());
  ASSERT_TRUE(c.send("GET,1\n"));  // socket_send_line
  const auto reply = c.readUntil(')');
  ASSERT_TRUE(reply);
  EXPECT_TRUE(std::regex_match(*reply, kUrRegex)) << *reply;
  EXPECT_EQ(*reply, urOk(1));
  EXPECT_TRUE(c.quiet()) << "bytes after ')' would break socket_read_ascii_float";
  EXPECT_EQ(lastRobot_, "ur-cell1");
}

TEST_F(robot_server, AbbReplyFitsOneSocketReceive) {
  RawTcpClient c(abb_->port());
  ASSERT_TRUE(c.send("GET,1#"));
  const auto reply = c.readOnce(80);
  ASSERT_TRUE(reply);
  EXPECT_TRUE(std::regex_match(*reply, kAbbRegex)) << *reply;
  EXPECT_LE(reply->size(), 80u);
  EXPECT_EQ(*reply, abbOk(1));
  EXPECT_TRUE(c.quiet());
  EXPECT_EQ(lastRobot_, "abb-cell1");
}

TEST_F(robot_server, AllTerminatorsAccepted) {
  RawTcpClient c(abb_->port());
  for (const char* req : {"GET,1#", "GET,1\r", "GET,1\n", "GET,1\r\n"}) {
    ASSERT_TRUE(c.send(req));
    const auto reply = c.readOnce(80);
    ASSERT_TRUE(reply) << req;
    EXPECT_EQ(*reply, abbOk(1));
  }
  EXPECT_TRUE(c.quiet()) << "CRLF must count as one terminator";
}

TEST_F(robot_server, DelayedReplyFromTimer) {
  RawTcpClient c(ur_->port());
  const auto t0 = Clock::now();
  ASSERT_TRUE(c.send("GET,2\n"));
  const auto reply = c.readUntil(')');
  const auto elapsed = Clock::now() - t0;
  ASSERT_TRUE(reply);
  EXPECT_EQ(*reply, urOk(2));
  EXPECT_GE(elapsed, 45ms);
  // The same connection keeps going.
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));
}

TEST_F(robot_server, GarbageGetsMinusOneAndTheConnectionStaysUsable) {
  RawTcpClient c(ur_->port());
  ASSERT_TRUE(c.send("HELLO\n"));
  EXPECT_EQ(c.readUntil(')'), urStatus(-1));
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));

  ASSERT_TRUE(c.send(std::string("\x00\x01\x02\xfe\xff\x80 binary\n", 14)));
  EXPECT_EQ(c.readUntil(')'), urStatus(-1));
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));

  // A 10 kB line: exactly one -1, then the stream is in sync again.
  ASSERT_TRUE(c.send(std::string(10 * 1024, 'Z') + "\n"));
  EXPECT_EQ(c.readUntil(')'), urStatus(-1));
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));
  EXPECT_TRUE(c.quiet());
}

TEST_F(robot_server, AbbGarbageAndBadArguments) {
  RawTcpClient c(abb_->port());
  ASSERT_TRUE(c.send("HELLO#"));
  EXPECT_EQ(c.readOnce(80), abbStatus(-1));
  ASSERT_TRUE(c.send("GET,0#"));
  EXPECT_EQ(c.readOnce(80), abbStatus(-2));
  ASSERT_TRUE(c.send("GET,abc#"));
  EXPECT_EQ(c.readOnce(80), abbStatus(-2));
  ASSERT_TRUE(c.send("GET,1#"));
  EXPECT_EQ(c.readOnce(80), abbOk(1));
  ASSERT_TRUE(c.send("GET,6#"));
  EXPECT_EQ(c.readOnce(80), "1,6,0.000,0.000,0.000,0.000,0.000,0.000");  // NO_PART_FOUND carries zeros
}

TEST_F(robot_server, PipelinedRequestsAreAnsweredInOrder) {
  RawTcpClient c(ur_->port());
  // The slow request first: its reply must still come first; the garbage's -1 waits its turn.
  ASSERT_TRUE(c.send("GET,2\nHELLO\nGET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(2));
  EXPECT_EQ(c.readUntil(')'), urStatus(-1));
  EXPECT_EQ(c.readUntil(')'), urOk(1));
  EXPECT_TRUE(c.quiet());

  // Merged ABB requests (two quick SocketSends): two replies, back to back.
  RawTcpClient a(abb_->port());
  ASSERT_TRUE(a.send("GET,1#GET,1#"));
  EXPECT_EQ(a.readExactly(2 * abbOk(1).size()), abbOk(1) + abbOk(1));
  EXPECT_TRUE(a.quiet());
}

TEST_F(robot_server, ManyQueuedRequestsAllAnswered) {
  // More than the per-connection queue holds: the server stops reading, TCP holds the
  // rest back, and every request is still answered once, in order.
  RawTcpClient c(ur_->port());
  std::string burst;
  for (int i = 0; i < 100; ++i) burst += (i % 10 == 0) ? "GET,2\n" : "GET,1\n";
  ASSERT_TRUE(c.send(burst));
  for (int i = 0; i < 100; ++i) {
    const auto reply = c.readUntil(')', 3000ms);
    ASSERT_TRUE(reply) << i;
    EXPECT_EQ(*reply, urOk(i % 10 == 0 ? 2 : 1)) << i;
  }
  EXPECT_TRUE(c.quiet());
  EXPECT_EQ(requests_.load(), 100);
}

TEST_F(robot_server, SecondClientUnaffectedByFirstClientsGarbage) {
  RawTcpClient bad(ur_->port());
  RawTcpClient good(ur_->port());
  // The bad client streams an endless line (the server is discarding it)...
  for (int i = 0; i < 8; ++i) ASSERT_TRUE(bad.send(std::string(1024, 'Q')));
  // ...and the good one is served immediately, also while the bad one has a slow request pending.
  ASSERT_TRUE(good.send("GET,1\n"));
  EXPECT_EQ(good.readUntil(')'), urOk(1));
  ASSERT_TRUE(bad.send("\nGET,7\n"));
  EXPECT_EQ(bad.readUntil(')'), urStatus(-1));
  const auto t0 = Clock::now();
  ASSERT_TRUE(good.send("GET,1\n"));
  EXPECT_EQ(good.readUntil(')'), urOk(1));
  EXPECT_LT(Clock::now() - t0, 200ms) << "one client's pending request must not block another";
  EXPECT_EQ(bad.readUntil(')'), urOk(7));
}

TEST_F(robot_server, ClientVanishingMidRequestIsHarmless) {
  {
    RawTcpClient gone(ur_->port());
    ASSERT_TRUE(gone.send("GET,7\n"));  // handler replies 300 ms later, after the close
  }
  {
    RawTcpClient reset(ur_->port());
    ASSERT_TRUE(reset.send("GET,2\n"));
    std::this_thread::sleep_for(10ms);
    reset.reset();  // RST
  }
  {
    RawTcpClient partial(ur_->port());
    ASSERT_TRUE(partial.send("GET,"));
  }
  RawTcpClient c(ur_->port());
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));
  std::this_thread::sleep_for(400ms);  // the late replies fire into closed connections
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));
  EXPECT_EQ(clients(*ur_), 1u);  // the vanished ones were cleaned up
}

TEST_F(robot_server, HalfClosedClientStillGetsItsReply) {
  RawTcpClient c(abb_->port());
  ASSERT_TRUE(c.send("GET,2#"));
  c.shutdownWrite();
  EXPECT_EQ(c.readOnce(80), abbOk(2));
  EXPECT_TRUE(c.waitClosed());
}

TEST_F(robot_server, HandlerBugsAnswerInternal) {
  RawTcpClient c(ur_->port());
  ASSERT_TRUE(c.send("GET,3\n"));  // handler drops the ReplyFn
  EXPECT_EQ(c.readUntil(')'), "(-8,0,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000)");
  ASSERT_TRUE(c.send("GET,4\n"));  // handler throws
  EXPECT_EQ(c.readUntil(')'), "(-8,0,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000)");
  ASSERT_TRUE(c.send("GET,5\n"));  // handler replies twice: the second is ignored
  EXPECT_EQ(c.readUntil(')'), urOk(5));
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));
  EXPECT_TRUE(c.quiet());
}

TEST_F(robot_server, IdleConnectionIsKept) {
  RawTcpClient c(abb_->port());
  ASSERT_TRUE(c.send("GET,1#"));
  EXPECT_EQ(c.readOnce(80), abbOk(1));
  EXPECT_TRUE(c.quiet(1500ms));  // no idle timeout closes it
  ASSERT_TRUE(c.send("GET,1#"));
  EXPECT_EQ(c.readOnce(80), abbOk(1));
}

// Issue 19, item 2 (decided): when full, a new connection from a robot's address takes the
// slot of that address's connection only if it is really stale (nothing in progress and
// silent for stale_after_ms). Before, the same robot's live connection was closed for any
// newcomer from its address (in a 20-minute soak that cost a normal robot one cycle).
TEST_F(robot_server, MaxClientsReplacesOnlyAStaleConnectionOfTheSameRobotAndRefusesOthers) {
  std::uint16_t port = 0;
  onIo([&] {
    RobotEndpoint ep = endpoint("ur-one", Dialect::Ur, "127.0.0.1", 0, 1);
    ep.staleAfterMs = 300;
    extra_.push_back(std::make_unique<RobotServer>(io_, ep, handler()));
    ASSERT_TRUE(extra_.back()->start());
    port = extra_.back()->port();
  });
  ASSERT_NE(port, 0);
  RawTcpClient first(port);
  ASSERT_TRUE(first.send("GET,1\n"));
  EXPECT_EQ(first.readUntil(')'), urOk(1));
  // Another address while full: refused, the robot's connection stays.
  RawTcpClient stranger(port, {.from = "127.0.0.2"});
  EXPECT_TRUE(stranger.waitClosed());
  // The same address while its connection is live (it just polled): the newcomer is
  // refused, the live connection keeps working.
  {
    RawTcpClient early(port);
    EXPECT_TRUE(early.waitClosed());
  }
  ASSERT_TRUE(first.send("GET,1\n"));
  EXPECT_EQ(first.readUntil(')'), urOk(1));
  // Silent for longer than stale_after_ms (e.g. its controller rebooted): replaced.
  std::this_thread::sleep_for(450ms);
  RawTcpClient second(port);
  EXPECT_TRUE(first.waitClosed());
  ASSERT_TRUE(second.send("GET,1\n"));
  EXPECT_EQ(second.readUntil(')'), urOk(1));
  EXPECT_EQ(clients(*extra_.back()), 1u);
}

TEST_F(robot_server, AllowedClientsOnly) {
  std::uint16_t port = 0;
  onIo([&] {
    RobotEndpoint ep = endpoint("abb-acl", Dialect::Abb, "0.0.0.0", 0, 8);
    ep.allowedClients = {"127.0.0.3"};
    extra_.push_back(std::make_unique<RobotServer>(io_, ep, handler()));
    ASSERT_TRUE(extra_.back()->start());
    port = extra_.back()->port();
  });
  RawTcpClient denied(port);  // from 127.0.0.1
  EXPECT_TRUE(denied.waitClosed());
  RawTcpClient allowed(port, {.from = "127.0.0.3"});
  ASSERT_TRUE(allowed.send("GET,1#"));
  EXPECT_EQ(allowed.readOnce(80), abbOk(1));

  // A bad address in the list is a start error naming it.
  Result<void> res;
  onIo([&] {
    RobotEndpoint ep = endpoint("abb-bad-acl", Dialect::Abb, "127.0.0.1", 0, 8);
    ep.allowedClients = {"robot.local"};
    RobotServer s(io_, ep, handler());
    res = s.start();
  });
  ASSERT_FALSE(res);
  EXPECT_NE(res.error().message.find("'robot.local' is not an IP address"), std::string::npos) << res.error().message;
}

TEST_F(robot_server, KeepaliveIsOnForEveryConnection) {
  // The kernel's view of the server side of the connection (iproute2's ss): a keepalive
  // timer runs on it, armed for the 10 s idle time of docs/protocols.md.
  RawTcpClient c(ur_->port());
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));
  const std::string cmd = fmt::format("ss -tnoH state established '( sport = :{} )' 2>&1", ur_->port());
  const std::string out = test::runCommand(cmd).out;
  std::smatch m;
  // iproute2 6.1 prints the time left as "9.988ms" for 9.988 s (checked against
  // TCP_KEEPIDLE = 10 s right after connecting); older versions print "9.988sec". Read the
  // number either way: it must be the 10 s idle time minus the few ms since connect.
  ASSERT_TRUE(std::regex_search(out, m, std::regex(R"(timer:\(keepalive,([0-9.]+)(ms|sec))"))) << out;
  const double left = std::stod(m[1].str());
  EXPECT_GT(left, 5.0) << out;
  EXPECT_LE(left, 10.0) << out;
}

TEST_F(robot_server, StartFailureNamesEndpointAddressAndPort) {
  const std::uint16_t busy = ur_->port();
  Result<void> res;
  onIo([&] {
    RobotServer clash(io_, endpoint("ur-clash", Dialect::Ur, "127.0.0.1", busy, 8), handler());
    res = clash.start();
  });
  ASSERT_FALSE(res);
  EXPECT_NE(res.error().message.find("ur-clash"), std::string::npos) << res.error().message;
  EXPECT_NE(res.error().message.find("127.0.0.1:" + std::to_string(busy)), std::string::npos) << res.error().message;
  // Starting twice is an error too.
  Result<void> again;
  onIo([&] { again = ur_->start(); });
  EXPECT_FALSE(again);
}

TEST_F(robot_server, StopClosesSessions) {
  RawTcpClient c(ur_->port());
  ASSERT_TRUE(c.send("GET,1\n"));
  EXPECT_EQ(c.readUntil(')'), urOk(1));
  ASSERT_TRUE(c.send("GET,7\n"));  // pending when the server stops: dropped, no crash
  std::this_thread::sleep_for(20ms);
  onIo([&] { ur_->stop(); });
  EXPECT_TRUE(c.waitClosed());
  std::this_thread::sleep_for(350ms);                              // the handler's late reply lands on a stopped server
  EXPECT_THROW(RawTcpClient again(ur_->port()), std::runtime_error);  // nothing listens any more
}

// The robot simulator against the real server: its strict validation accepts what the
// server sends, and rejects the other dialect (so the check can fail).
struct SimRun {
  int exitCode = -1;
  std::vector<nlohmann::json> lines;
};

SimRun runSim(const std::string& args) {
  SimRun run;
  const std::string cmd = fmt::format("{}/vgr-sim-robot {} --json 2>/dev/null", VGR_BIN_DIR, args);
  const auto ran = test::runCommand(cmd);
  const std::string& out = ran.out;
  run.exitCode = ran.exitCode;
  std::size_t pos = 0;
  while (pos < out.size()) {
    const std::size_t eol = out.find('\n', pos);
    const std::string line = out.substr(pos, eol - pos);
    if (!line.empty()) run.lines.push_back(nlohmann::json::parse(line, nullptr, false));
    if (eol == std::string::npos) break;
    pos = eol + 1;
  }
  return run;
}

TEST_F(robot_server, SimRobotAcceptsRealRepliesAndRejectsTheWrongDialect) {
  if (::access(VGR_BIN_DIR "/vgr-sim-robot", X_OK) != 0) {
    FAIL() << "vgr-sim-robot not built (tests/CMakeLists.txt builds it before the integration tests)";
  }
  std::uint16_t fanucPort = 0, binaryPort = 0;
  onIo([&] {
    for (const auto& [name, dialect] : {std::pair{"fanuc-cell1", Dialect::Fanuc}, {"binary-cell1", Dialect::Binary}}) {
      extra_.push_back(std::make_unique<RobotServer>(io_, endpoint(name, dialect, "127.0.0.1", 0, 8), handler()));
      ASSERT_TRUE(extra_.back()->start());
      (dialect == Dialect::Fanuc ? fanucPort : binaryPort) = extra_.back()->port();
    }
  });
  ASSERT_NE(fanucPort, 0);
  ASSERT_NE(binaryPort, 0);
  for (const auto& [dialect, port] : {std::pair<std::string, std::uint16_t>{"ur", ur_->port()},
                                      {"abb", abb_->port()},
                                      {"fanuc", fanucPort},
                                      {"binary", binaryPort}}) {
    const SimRun run = runSim(fmt::format("--dialect {} --port {} --count 3 --interval-ms 10", dialect, port));
    EXPECT_EQ(run.exitCode, 0) << dialect;
    ASSERT_EQ(run.lines.size(), 4u) << dialect;
    for (int i = 0; i < 3; ++i) {
      const nlohmann::json& l = run.lines[static_cast<std::size_t>(i)];
      EXPECT_EQ(l.value("robot", ""), dialect);
      EXPECT_EQ(l.value("n", 0), i + 1);
      EXPECT_TRUE(l.value("valid", false)) << l.dump();
      EXPECT_EQ(l.value("status", 99), 0);
      EXPECT_EQ(l.value("cycle", 0), 1);
      EXPECT_NEAR(l.value("x_mm", 0.0), 512.3, 1e-9);
      EXPECT_NEAR(l.value("y_mm", 0.0), -120.05, 1e-9);
      EXPECT_NEAR(l.value("z_mm", 0.0), 35.0, 1e-9);
      EXPECT_NEAR(l.value("rz_deg", 0.0), -12.5, 1e-9);
    }
    const nlohmann::json& summary = run.lines.back();
    EXPECT_EQ(summary.value("replies", 0), 3);
    EXPECT_EQ(summary.value("valid", 0), 3);
    EXPECT_EQ(summary.value("invalid", -1), 0);
    EXPECT_EQ(summary.value("ok", 0), 3);
  }

  // A UR program talking to the ABB endpoint: no ')' ever comes -> invalid, exit 1.
  const SimRun wrong = runSim(fmt::format("--dialect ur --port {} --count 1 --timeout-ms 300", abb_->port()));
  EXPECT_EQ(wrong.exitCode, 1);
  ASSERT_EQ(wrong.lines.size(), 2u);
  EXPECT_FALSE(wrong.lines[0].value("valid", true));
  EXPECT_EQ(wrong.lines[0].value("raw", ""), abbOk(1));
  EXPECT_EQ(wrong.lines[1].value("invalid", 0), 1);

  // A FANUC program reading an ABB reply: no CR LF ever comes -> invalid.
  const SimRun wrongFanuc = runSim(fmt::format("--dialect fanuc --port {} --count 1 --timeout-ms 300", abb_->port()));
  EXPECT_EQ(wrongFanuc.exitCode, 1);
  ASSERT_EQ(wrongFanuc.lines.size(), 2u);
  EXPECT_FALSE(wrongFanuc.lines[0].value("valid", true));
}

}  // namespace
}  // namespace vgr::protocol
