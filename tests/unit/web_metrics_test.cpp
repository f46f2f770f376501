// The web server (daemon/web_server.hpp) over real loopback sockets: routing, 404, 405,
// HEAD, keep-alive, the header limit; and the metrics text (daemon/metrics.hpp): series
// made up front, cycle counts and histograms, sampled values.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <poll.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <iterator>
#include <string>
#include <thread>

#include <boost/asio/io_context.hpp>
#include <gtest/gtest.h>

#include "daemon/metrics.hpp"
#include "daemon/web_server.hpp"

namespace vgr::daemon {
namespace {

class Client {
 public:
  explicit Client(int port) : fd_(::socket(AF_INET, SOCK_STREAM, 0)) {
    sockaddr_in a{};
    a.sin_family = AF_INET;
    a.sin_port = htons(static_cast<std::uint16_t>(port));
    a.sin_addr.s_addr = htonl(INADDR_LOOPBACK);
    connected_ = ::connect(fd_, reinterpret_cast<sockaddr*>(&a), sizeof a) == 0;
  }
  ~Client() { ::close(fd_); }
  bool send(const std::string& s) { return ::send(fd_, s.data(), s.size(), MSG_NOSIGNAL) == static_cast<ssize_t>(s.size()); }
  // Reads until `until` appears (then returns everything read) or EOF / 3 s.
  std::string read(const std::string& until = "") {
    const auto end = std::chrono::steady_clock::now() + std::chrono::seconds(3);
    while (std::chrono::steady_clock::now() < end) {
      if (!until.empty() && buf_.find(until) != std::string::npos) break;
      pollfd p{fd_, POLLIN, 0};
      if (::poll(&p, 1, 20) <= 0) continue;
      char b[4096];
      const ssize_t n = ::recv(fd_, b, sizeof b, 0);
      if (n <= 0) {
        eof_ = true;
        break;
      }
      buf_.append(b, static_cast<std::size_t>(n));
    }
    std::string out;
    out.swap(buf_);
    return out;
  }
  bool connected() const { return connected_; }
  bool eof() const { return eof_; }

 private:
  int fd_;
  bool connected_ = false, eof_ = false;
  std::string buf_;
};

class web_server : public ::testing::Test {
 protected:
  void SetUp() override {
    server_ = std::make_unique<WebServer>(io_, WebOptions{"127.0.0.1", 0});
    server_->route("/hello", [](const HttpRequest& r) { return HttpReply{200, "text/plain", "hello " + r.query, {}}; });
    ASSERT_TRUE(server_->start().has_value());
    ASSERT_GT(server_->port(), 0);
    thread_ = std::thread([this] { io_.run(); });
  }
  void TearDown() override {
    io_.stop();
    thread_.join();
    server_.reset();
  }
  boost::asio::io_context io_;
  std::unique_ptr<WebServer> server_;
  std::thread thread_;
};

TEST_F(web_server, RoutesAndRefuses) {
  Client c(server_->port());
  ASSERT_TRUE(c.connected());
  // Keep-alive: two requests on one connection.
  ASSERT_TRUE(c.send("GET /hello?x=1 HTTP/1.1\r\nHost: a\r\n\r\n"));
  const std::string first = c.read("hello x=1");
  EXPECT_NE(first.find("HTTP/1.1 200 OK"), std::string::npos) << first;
  EXPECT_NE(first.find("Content-Type: text/plain"), std::string::npos);
  ASSERT_TRUE(c.send("GET /nope HTTP/1.1\r\nHost: a\r\n\r\n"));
  EXPECT_NE(c.read("\r\n\r\n").find("HTTP/1.1 404"), std::string::npos);
  ASSERT_TRUE(c.send("DELETE /hello HTTP/1.1\r\nHost: a\r\n\r\n"));
  const std::string del = c.read("read-only\n");
  EXPECT_NE(del.find("HTTP/1.1 405"), std::string::npos) << del;
  EXPECT_NE(del.find("Allow: GET, HEAD"), std::string::npos) << del;
  ASSERT_TRUE(c.send("HEAD /hello HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n"));
  const std::string head = c.read();
  EXPECT_NE(head.find("Content-Length: 6"), std::string::npos) << head;
  EXPECT_EQ(head.substr(head.find("\r\n\r\n") + 4), "");
  EXPECT_TRUE(c.eof());
}

TEST_F(web_server, OverlongHeadClosesTheConnection) {
  Client c(server_->port());
  ASSERT_TRUE(c.connected());
  c.send("GET /hello HTTP/1.1\r\nX-Big: " + std::string(16 * 1024, 'a') + "\r\n\r\n");
  const std::string r = c.read();
  EXPECT_EQ(r.find("200 OK"), std::string::npos);
  EXPECT_TRUE(c.eof());
  // The server still serves others.
  Client d(server_->port());
  d.send("GET /hello HTTP/1.1\r\nHost: a\r\nConnection: close\r\n\r\n");
  EXPECT_NE(d.read().find("200 OK"), std::string::npos);
}

TEST(metrics, SeriesCountsAndSamples) {
  Metrics m("cellA", {1, 2}, {"ur5"}, "1.2.3");
  m.addSampler([](std::vector<SampledMetric>& out) {
    out.push_back({"vgr_camera_frames_total", "frames", SampledMetric::Type::Counter, {{"camera", "cam0"}}, 41});
    out.push_back({"vgr_camera_streaming", "streaming", SampledMetric::Type::Gauge, {{"camera", "cam0"}}, 1});
  });
  const std::string before = m.render();
  // Every job x status exists from the start, at zero.
  EXPECT_NE(before.find("vgr_cycles_total{job=\"2\",status=\"CAMERA_ERROR\"} 0"), std::string::npos) << before;
  EXPECT_NE(before.find("vgr_robot_replies_total{robot=\"ur5\",status=\"OK\"} 0"), std::string::npos);
  EXPECT_NE(before.find("vgr_build_info{cell=\"cellA\",version=\"1.2.3\"} 1"), std::string::npos);

  CycleResult ok;
  ok.jobId = 1;
  ok.status = Status::Ok;
  ok.totalMs = 30;
  ok.grabMs = 12;
  ok.locateMs = 15;
  ok.parts.resize(2);
  m.cycleDone(ok);
  m.cycleDone(ok);
  CycleResult bad = ok;
  bad.jobId = 99;
  bad.status = Status::JobNotFound;
  bad.parts.clear();
  m.cycleDone(bad);
  m.triggered(TriggerSource::Modbus, true);
  m.triggered(TriggerSource::Modbus, false);
  m.robotReplied("ur5", Status::NoPartFound);
  m.robotReplied("someone-else", Status::Ok);  // unknown endpoint: ignored
  m.robotReplied("ur5", Status::NotPermitted);  // counted under its own name, not as INTERNAL

  const std::string text = m.render();
  EXPECT_NE(text.find("# TYPE vgr_cycles_total counter"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_cycles_total{job=\"1\",status=\"OK\"} 2"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_cycles_total{job=\"unknown\",status=\"JOB_NOT_FOUND\"} 1"), std::string::npos) << text;
  EXPECT_NE(text.find("# TYPE vgr_cycle_seconds histogram"), std::string::npos);
  EXPECT_NE(text.find("vgr_cycle_seconds_count{job=\"1\"} 2"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_cycle_seconds_bucket{job=\"1\",le=\"0.05\"} 2"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_cycle_seconds_bucket{job=\"1\",le=\"0.02\"} 0"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_cycle_stage_seconds_count{stage=\"grab\"} 3"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_parts_found_total 4"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_triggers_total{source=\"modbus\"} 1"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_trigger_overruns_total{source=\"modbus\"} 1"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_robot_replies_total{robot=\"ur5\",status=\"NO_PART_FOUND\"} 1"), std::string::npos);
  EXPECT_NE(text.find("vgr_robot_replies_total{robot=\"ur5\",status=\"NOT_PERMITTED\"} 1"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_robot_replies_total{robot=\"ur5\",status=\"INTERNAL\"} 0"), std::string::npos) << text;
  EXPECT_NE(text.find("# TYPE vgr_camera_frames_total counter"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_camera_frames_total{camera=\"cam0\"} 41"), std::string::npos) << text;
  EXPECT_NE(text.find("vgr_camera_streaming{camera=\"cam0\"} 1"), std::string::npos) << text;
}

// kAllStatuses is the one list of statuses: every value statusName names (anything else is
// named INTERNAL) is in it exactly once, so the metrics' series cover every status.
TEST(status, EveryNamedStatusIsInTheList) {
  std::size_t named = 0;
  for (int code = -64; code <= 64; ++code) {
    const auto s = static_cast<Status>(code);
    const bool isNamed = statusName(s) != "INTERNAL" || s == Status::Internal;
    const auto inList = std::count(std::begin(kAllStatuses), std::end(kAllStatuses), s);
    EXPECT_EQ(inList, isNamed ? 1 : 0) << "status code " << code << " (" << statusName(s) << ")";
    named += isNamed;
  }
  EXPECT_EQ(named, std::size(kAllStatuses));
}

}  // namespace
}  // namespace vgr::daemon
