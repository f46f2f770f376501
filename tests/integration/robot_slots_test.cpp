// Robot connection slots (protocol/robot_server.hpp) over real loopback sockets: silent
// connections are closed after the endpoint's idle timeout and free their slots, a polling
// robot is never idle, and when full a reconnect from a robot's address replaces its
// connection that has been silent the longest, only if that one is stale (nothing in
// progress, silent for stale_after_ms), never one whose robot waits for its reply; one
// address holds at most max_clients_per_address; JOB and TRIG only from control_clients;
// a request must be complete request_timeout after its first byte (slowloris).
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
#include <boost/asio/steady_timer.hpp>

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

struct SlotOptions {
  std::size_t maxClients = 8;
  std::size_t perAddress = 0;
  int idleTimeoutMs = 0;
  int staleAfterMs = 10000;
  int requestTimeoutMs = 5000;
  std::vector<std::string> controlClients;
};

class robot_slots : public ::testing::Test {
 protected:
  void start(std::size_t maxClients, int idleTimeoutMs, int staleAfterMs = 10000) {
    SlotOptions o;
    o.maxClients = maxClients;
    o.idleTimeoutMs = idleTimeoutMs;
    o.staleAfterMs = staleAfterMs;
    start(o);
  }
  // Job 1: answered at once; job 2: after 600 ms (a robot waiting for its part). Cycle = job.
  void start(const SlotOptions& o) {
    RobotEndpoint ep;
    ep.name = "ur";
    ep.dialect = Dialect::Ur;
    ep.bind = "0.0.0.0";
    ep.port = 0;
    ep.maxClients = o.maxClients;
    ep.maxClientsPerAddress = o.perAddress;
    ep.idleTimeoutMs = o.idleTimeoutMs;
    ep.staleAfterMs = o.staleAfterMs;
    ep.requestTimeoutMs = o.requestTimeoutMs;
    ep.controlClients = o.controlClients;
    server_ = std::make_unique<RobotServer>(io_.io(), ep, [this](const std::string&, const RobotRequest& req, ReplyFn reply) {
      RobotReply r;
      r.cycleId = static_cast<std::uint32_t>(req.job);
      if (req.job != 2) {
        reply(r);
        return;
      }
      auto timer = std::make_shared<asio::steady_timer>(io_.io(), 600ms);
      timer->async_wait([timer, reply, r](const boost::system::error_code&) { reply(r); });
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
  start(2, 0, 50);
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

// Issue 19, item 2: a robot waiting for its reply is never stale. Before, a second
// connection from its address (e.g. the robot's own service task, or another program on
// its controller) closed the waiting one when the endpoint was full: the part it waited
// for was lost to it.
TEST_F(robot_slots, AWaitingRobotIsNeverReplaced) {
  SlotOptions o;
  o.maxClients = 1;
  o.staleAfterMs = 100;
  start(o);
  RawClient waiting(port_, "127.0.0.1");
  ASSERT_TRUE(waiting.connected());
  ASSERT_TRUE(waiting.send("GET,2\n"));  // answered after 600 ms
  std::this_thread::sleep_for(300ms);    // silent for 300 ms > stale_after_ms, but waiting
  RawClient newcomer(port_, "127.0.0.1");
  EXPECT_TRUE(newcomer.closedWithin(1000ms)) << "the newcomer must be refused";
  EXPECT_EQ(waiting.readUntil(')', 2000ms).rfind("(0,2,", 0), 0u) << "the waiting robot lost its reply";
  EXPECT_EQ(clients(), 1u);
}

// One address holds at most max_clients_per_address slots: a storm or a stuck program on
// one host leaves the others theirs.
TEST_F(robot_slots, PerAddressLimitLeavesSlotsForOtherAddresses) {
  SlotOptions o;
  o.maxClients = 4;
  o.perAddress = 2;
  start(o);
  RawClient a1(port_, "127.0.0.1"), a2(port_, "127.0.0.1");
  ASSERT_TRUE(a1.connected() && a2.connected());
  ASSERT_TRUE(a1.get() && a2.get());
  RawClient a3(port_, "127.0.0.1");
  EXPECT_TRUE(a3.closedWithin(1000ms)) << "a third connection from 127.0.0.1";
  RawClient b1(port_, "127.0.0.2"), b2(port_, "127.0.0.2");
  ASSERT_TRUE(b1.connected() && b2.connected());
  EXPECT_TRUE(b1.get() && b2.get());
  EXPECT_TRUE(a1.get() && a2.get());
  EXPECT_EQ(clients(), 4u);
  RobotServerStats st;
  onIo([&] { st = server_->stats(); });
  EXPECT_EQ(st.accepted, 4u);
  EXPECT_EQ(st.refusedFull, 1u);
}

// Issue 19, item 6: JOB and TRIG change what a robot gets and start cycles: only from
// control_clients. Before, any client of the port could switch the robot's job for good.
TEST_F(robot_slots, ControlRequestsOnlyFromControlClients) {
  SlotOptions o;
  o.controlClients = {"127.0.0.3"};
  start(o);
  RawClient other(port_, "127.0.0.1");
  ASSERT_TRUE(other.send("JOB,1\n"));
  EXPECT_EQ(other.readUntil(')', 2000ms).rfind("(-10,0,", 0), 0u);
  ASSERT_TRUE(other.send("TRIG,1\n"));
  EXPECT_EQ(other.readUntil(')', 2000ms).rfind("(-10,0,", 0), 0u);
  EXPECT_TRUE(other.get()) << "GET stays open to every client; the connection survives";
  RawClient control(port_, "127.0.0.3");
  ASSERT_TRUE(control.send("JOB,1\n"));
  EXPECT_EQ(control.readUntil(')', 2000ms).rfind("(0,1,", 0), 0u);
  RobotServerStats st;
  onIo([&] { st = server_->stats(); });
  EXPECT_EQ(st.controlRefused, 2u);
}

// A request must be complete request_timeout after its first byte: a peer dribbling bytes
// (slowloris) or a line that never ends holds its slot no longer. Before, with no idle
// timeout configured, it held the slot forever.
TEST_F(robot_slots, IncompleteRequestIsClosedAfterTheRequestTimeout) {
  SlotOptions o;
  o.requestTimeoutMs = 400;
  start(o);
  RawClient slow(port_, "127.0.0.1");
  const auto t0 = Clock::now();
  for (const char c : std::string("GET,")) {
    ASSERT_TRUE(slow.send(std::string(1, c)));
    std::this_thread::sleep_for(100ms);
  }
  EXPECT_TRUE(slow.closedWithin(1000ms));
  EXPECT_LT(Clock::now() - t0, 1500ms);
  RawClient good(port_, "127.0.0.1");
  EXPECT_TRUE(good.get());
  std::this_thread::sleep_for(600ms);
  EXPECT_TRUE(good.get()) << "a complete request resets nothing: an idle robot is not closed";
}

}  // namespace
}  // namespace vgr::protocol
