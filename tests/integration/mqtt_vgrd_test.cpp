// vgrd's MQTT sink (docs/plant.md) against a real broker: `mosquitto -c FILE` on a free
// loopback port, `mosquitto_sub` as the client (Debian mosquitto, mosquitto-clients).
// N cycles triggered by a libmodbus PLC -> N result messages, each cycle once, matching
// the journal; the retained status says online; kill -9 of vgrd -> the will ("offline").
// A broker restart: results made while it is away wait in the bounded queue (the oldest
// dropped and counted in /metrics), and reach a durable subscriber once it is back.
#include <arpa/inet.h>
#include <netinet/in.h>
#include <sys/socket.h>
#include <unistd.h>

#include <algorithm>
#include <map>
#include <set>

#include "modbus_cell.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

class mqtt_vgrd : public ModbusCell {
 protected:
  // mosquitto_sub -v prints "TOPIC PAYLOAD" per message.
  struct Message {
    std::string topic;
    nlohmann::json payload;
  };

  // `persistent`: the broker keeps sessions across its restarts (saved on SIGTERM).
  void startBroker(bool persistent = false) {
    if (port_ == 0) port_ = vgr::test::freeLoopbackPort();
    ASSERT_GT(port_, 0);
    brokerDir_ = std::filesystem::temp_directory_path() / ("vgr-mqtt-" + std::to_string(::getpid()));
    std::filesystem::create_directories(brokerDir_);
    // Started as root, mosquitto drops to user mosquitto: it must be able to save its database here.
    std::filesystem::permissions(brokerDir_, std::filesystem::perms::all);
    const auto conf = brokerDir_ / "mosquitto.conf";
    std::ofstream(conf) << "listener " << port_ << " 127.0.0.1\nallow_anonymous true\n"
                        << (persistent ? "persistence true\npersistence_location " + brokerDir_.string() + "/\n"
                                       : std::string("persistence false\n"));
    auto p = vgr::test::ChildProcess::spawn({"/usr/sbin/mosquitto", "-c", conf.string()}, (brokerDir_ / "broker.log").string());
    ASSERT_TRUE(p.has_value());
    broker_ = std::make_unique<vgr::test::ChildProcess>(std::move(*p));
    for (int i = 0; i < 100 && portFree(port_); ++i) std::this_thread::sleep_for(20ms);
    ASSERT_FALSE(portFree(port_)) << "mosquitto did not listen on " << port_;
  }

  // `durableId`: a persistent session (-c -i ID) whose QoS 1 messages the broker keeps.
  void startSubscriber(const std::string& durableId = "") {
    std::vector<std::string> argv = {"/usr/bin/mosquitto_sub", "-h", "127.0.0.1", "-p", std::to_string(port_),
                                     "-q", "1", "-v", "-t", "vgr/sim-cell/#"};
    if (!durableId.empty()) argv.insert(argv.end(), {"-c", "-i", durableId});
    auto p = vgr::test::ChildProcess::spawn(argv, (brokerDir_ / "sub.log").string());
    ASSERT_TRUE(p.has_value());
    sub_ = std::make_unique<vgr::test::ChildProcess>(std::move(*p));
  }

  std::optional<Message> next(std::chrono::milliseconds timeout) {
    auto line = sub_->readLine(timeout);
    if (!line) return std::nullopt;
    const auto sp = line->find(' ');
    Message m{line->substr(0, sp), nlohmann::json::parse(sp == std::string::npos ? "" : line->substr(sp + 1), nullptr, false)};
    return m;
  }

  std::string mqttSection() const {
    return "\nmqtt:\n  host: 127.0.0.1\n  port: " + std::to_string(port_) +
           "\n  prefix: vgr\n  reconnect_min_s: 1\n  reconnect_max_s: 2\n";
  }

  void TearDown() override {
    sub_.reset();
    ModbusCell::TearDown();
    broker_.reset();
    std::error_code ec;
    if (!HasFailure()) std::filesystem::remove_all(brokerDir_, ec);
  }

  int port_ = 0;
  std::filesystem::path brokerDir_;
  std::unique_ptr<vgr::test::ChildProcess> broker_, sub_;
};

TEST_F(mqtt_vgrd, every_cycle_once_and_the_will_on_kill_9) {
  ASSERT_NO_FATAL_FAILURE(startBroker());
  ASSERT_NO_FATAL_FAILURE(startSubscriber());
  ASSERT_NO_FATAL_FAILURE(startCell([this](std::string yaml) { return yaml + mqttSection(); }));

  // The retained status comes first: online, with the version.
  std::optional<Message> status;
  for (auto m = next(5s); m; m = next(5s)) {
    if (m->topic == "vgr/sim-cell/status" && m->payload.value("state", "") == "online") {
      status = m;
      break;
    }
  }
  ASSERT_TRUE(status.has_value()) << log("vgrd.log");
  EXPECT_FALSE(status->payload.value("version", "").empty());

  constexpr int kCycles = 10;
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  for (int i = 1; i <= kCycles; ++i) {
    const auto r = triggerCounter(ctx, static_cast<std::uint16_t>(200 + i), 5s);
    ASSERT_TRUE(r.status & 0x08) << "RESULT_VALID, cycle " << i;
  }
  modbus_close(ctx);
  modbus_free(ctx);

  std::map<std::uint32_t, nlohmann::json> results;  // by cycle id
  int messages = 0;
  const auto until = Clock::now() + 10s;
  while (messages < kCycles && Clock::now() < until) {
    auto m = next(500ms);
    if (!m || m->topic != "vgr/sim-cell/result") continue;
    ASSERT_TRUE(m->payload.is_object());
    ++messages;
    results[m->payload["cycle"].get<std::uint32_t>()] = m->payload;
  }
  EXPECT_EQ(messages, kCycles);
  EXPECT_EQ(results.size(), static_cast<std::size_t>(kCycles)) << "a cycle arrived twice";
  for (std::uint32_t id = 1; id <= kCycles; ++id) {
    const nlohmann::json j = journalEntry(id);
    ASSERT_FALSE(j.is_null());
    ASSERT_TRUE(results.count(id)) << "cycle " << id << " never arrived";
    EXPECT_EQ(results[id], j) << "the message is the journal line";
  }
  // No more than N.
  for (auto m = next(300ms); m; m = next(300ms)) EXPECT_NE(m->topic, "vgr/sim-cell/result") << m->payload;

  // kill -9: no clean disconnect, the broker publishes the will.
  vgrd_->kill9();
  bool offline = false;
  for (auto m = next(5s); m && !offline; m = next(5s))
    offline = m->topic == "vgr/sim-cell/status" && m->payload.value("state", "") == "offline";
  EXPECT_TRUE(offline) << "no will after kill -9";
}

// One HTTP GET of /metrics; the value of the sample `name` (no labels), -1 when absent.
double metric(int webPort, const std::string& name) {
  const std::string out = vgr::test::httpRequest(static_cast<std::uint16_t>(webPort), "GET", "/metrics");
  const auto p = out.find("\n" + name + " ");
  return p == std::string::npos ? -1 : std::stod(out.substr(p + name.size() + 2));
}

TEST_F(mqtt_vgrd, results_resume_after_a_broker_restart_with_the_drops_counted) {
  ASSERT_NO_FATAL_FAILURE(startBroker(true));
  ASSERT_NO_FATAL_FAILURE(startSubscriber("vgr-test-sub"));
  const int web = vgr::test::freeLoopbackPort();
  constexpr int kQueue = 3;
  ASSERT_NO_FATAL_FAILURE(startCell([this, web](std::string yaml) {
    return yaml + mqttSection() + "  queue: " + std::to_string(kQueue) + "\nweb:\n  port: " + std::to_string(web) + "\n";
  }));
  for (int i = 0; i < 100 && metric(web, "vgr_mqtt_connected") != 1; ++i) std::this_thread::sleep_for(50ms);
  ASSERT_EQ(metric(web, "vgr_mqtt_connected"), 1);

  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  std::uint16_t trigger = 300;
  auto cycle = [&] {
    const auto r = triggerCounter(ctx, ++trigger, 5s);
    ASSERT_TRUE(r.status & 0x08) << "RESULT_VALID";
  };
  ASSERT_NO_FATAL_FAILURE(cycle());  // cycle 1, broker up

  // The broker goes away (saving the subscriber's session); vgrd notices.
  sub_.reset();
  ASSERT_EQ(broker_->stop(), 0);
  for (int i = 0; i < 100 && metric(web, "vgr_mqtt_connected") != 0; ++i) std::this_thread::sleep_for(50ms);
  ASSERT_EQ(metric(web, "vgr_mqtt_connected"), 0);
  constexpr int kAway = 5;  // cycles 2..6: the queue keeps the newest kQueue, drops the rest
  for (int i = 0; i < kAway; ++i) ASSERT_NO_FATAL_FAILURE(cycle());
  // vgrd hands a result to MQTT after the PLC has it (vgrd_app.cpp), so the last cycle's
  // RESULT_VALID can come before its enqueue: wait for the queue to take it, then compare.
  for (int i = 0; i < 100 && metric(web, "vgr_mqtt_dropped_total") + metric(web, "vgr_mqtt_queued") < kAway; ++i)
    std::this_thread::sleep_for(20ms);
  EXPECT_EQ(metric(web, "vgr_mqtt_dropped_total"), kAway - kQueue);
  EXPECT_EQ(metric(web, "vgr_mqtt_queued"), kQueue);

  // Back: vgrd reconnects within its back-off (<= 2 s) and delivers the queue.
  ASSERT_NO_FATAL_FAILURE(startBroker(true));
  for (int i = 0; i < 100 && metric(web, "vgr_mqtt_connects_total") < 2; ++i) std::this_thread::sleep_for(50ms);
  EXPECT_EQ(metric(web, "vgr_mqtt_connects_total"), 2);
  ASSERT_NO_FATAL_FAILURE(cycle());  // cycle 7, broker back
  ASSERT_NO_FATAL_FAILURE(startSubscriber("vgr-test-sub"));

  std::set<std::uint32_t> got;
  const auto until = Clock::now() + 10s;
  auto after = [&] { return std::count_if(got.begin(), got.end(), [](std::uint32_t c) { return c > 1; }); };
  while (after() < kQueue + 1 && Clock::now() < until) {
    auto m = next(500ms);
    if (m && m->topic == "vgr/sim-cell/result") {
      EXPECT_TRUE(got.insert(m->payload["cycle"].get<std::uint32_t>()).second) << "twice: " << m->payload;
    }
  }
  modbus_close(ctx);
  modbus_free(ctx);
  // Cycle 1 was delivered before the restart (the durable session had acknowledged it or
  // gets it now); 2 and 3 were dropped; 4..6 waited in vgrd's queue; 7 came after.
  got.erase(1);
  EXPECT_EQ(got, (std::set<std::uint32_t>{4, 5, 6, 7})) << log("vgrd.log");
  EXPECT_EQ(metric(web, "vgr_mqtt_dropped_total"), kAway - kQueue);
}

}  // namespace
