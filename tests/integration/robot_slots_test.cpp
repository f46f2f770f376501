// Robot connection slots (protocol/robot_server.hpp) over real loopback sockets: silent
// connections are closed after the endpoint's idle timeout and free their slots, a polling
// robot is never idle, and when full a reconnect from a robot's address replaces its
// connection that has been silent the longest, not its live one.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <gtest/gtest.h>

#include <chrono>
#include <functional>
#include <future>
#include <memory>
#include <string>
#include <thread>

#include <boost/asio/executor_work_guard.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/post.hpp>

#include "protocol/robot_server.hpp"
#include "tests/support/io_thread.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace vgr::protocol {
namespace {

using namespace std::chrono_literals;
namespace asio = boost::asio;
using Clock = std::chrono::steady_clock;

// A robot connection (from a chosen local address) that can poll once.
struct RawClient : vgr::test::TestSocket {
  RawClient(std::uint16_t port, const char* from) : TestSocket(port, from) {}
  // One GET,1 and its reply.
  bool get() { return send("GET,1\n") && readUntil(')', 2000ms).rfind("(0,1,", 0) == 0; }
};

class robot_slots : public ::testing::Test {
 protected:
  void start(std::size_t maxClients, int idleTimeoutMs) {
    RobotEndpoint ep;
    ep.name = "ur";
    ep.dialect = Dialect::Ur;
    ep.bind = "0.0.0.0";
    ep.port = 0;
    ep.maxClients = maxClients;
    ep.idleTimeoutMs = idleTimeoutMs;
    server_ = std::make_unique<RobotServer>(io_.io(), ep, [](const std::string&, const RobotRequest& req, ReplyFn reply) {
      RobotReply r;
      r.cycleId = static_cast<std::uint32_t>(req.job);
      reply(r);
    });
    ASSERT_TRUE(server_->start());
    port_ = server_->port();
    io_.start();
    started_ = true;
  }
  void TearDown() override {
    if (started_) io_.run([this] { server_->stop(); });
    io_.stop();
  }
  void onIo(const std::function<void()>& f) { io_.run(f); }
  std::size_t clients() {
    std::size_t n = 0;
    onIo([&] { n = server_->clientCount(); });
    return n;
  }
  vgr::test::IoThread io_;  // the I/O thread, as vgrd's
  bool started_ = false;
  std::unique_ptr<RobotServer> server_;
  std::uint16_t port_ = 0;
};

TEST_F(robot_slots, SilentConnectionsAreClosedAfterTheIdleTimeoutAndFreeTheirSlots) {
  start(3, 300);
  RawClient poller(port_, "127.0.0.1");
  RawClient idle1(port_, "127.0.0.1"), idle2(port_, "127.0.0.1");
  ASSERT_TRUE(poller.connected() && idle1.connected() && idle2.connected());
  std::this_thread::sleep_for(50ms);
  {
    RawClient other(port_, "127.0.0.2");  // full, another address: refused
    EXPECT_TRUE(other.closedWithin(1000ms));
  }
  const auto t0 = Clock::now();
  while (Clock::now() - t0 < 800ms) {
    ASSERT_TRUE(poller.get()) << "a polling robot is not idle";
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_TRUE(idle1.closedWithin(100ms));
  EXPECT_TRUE(idle2.closedWithin(100ms));
  RawClient other(port_, "127.0.0.2");
  ASSERT_TRUE(other.connected());
  EXPECT_TRUE(other.get()) << "a freed slot serves another robot";
  EXPECT_TRUE(poller.get());
}

// Full; the robot's first connection is live (it polls), its second one silent. A third
// connection from the same address replaces the silent one.
TEST_F(robot_slots, ReconnectReplacesTheSilentConnectionNotTheLiveOne) {
  start(2, 0);
  RawClient live(port_, "127.0.0.1");
  ASSERT_TRUE(live.connected());
  ASSERT_TRUE(live.get());
  RawClient silent(port_, "127.0.0.1");
  ASSERT_TRUE(silent.connected());
  std::this_thread::sleep_for(100ms);
  ASSERT_TRUE(live.get());
  RawClient again(port_, "127.0.0.1");
  ASSERT_TRUE(again.connected());
  EXPECT_TRUE(silent.closedWithin(1000ms));
  EXPECT_TRUE(live.get()) << "the live connection was replaced";
  EXPECT_TRUE(again.get());
  EXPECT_EQ(clients(), 2u);
}

}  // namespace
}  // namespace vgr::protocol
