// Soak: the real vgrd + camera emulator, a libmodbus PLC triggering in counter mode at
// 10 Hz for 60 s, and ten raw-TCP robot clients (5 UR on 50010, 5 ABB on 50011) polling
// GET,1 back to back (never LAST). Checks:
//   - every trigger gets exactly one RESULT_VALID, with RESULT_ID = its ACQ_ID, all distinct,
//     and status OK (nothing lost);
//   - the journal has exactly one line per trigger, the same cycle ids;
//   - no robot client ever sees the same cycle id twice; every cycle id a robot sees is in
//     the journal; no reply is malformed;
//   - every cycle reaches at least one client of each endpoint. vgrd delivers a fresh
//     result once per ENDPOINT name (docs/architecture.md): the clients of one endpoint
//     share the "delivered" marker, so a part goes to one client waiting when it arrives,
//     the others wait for the next one.
// The five clients of an endpoint connect from five addresses (127.0.0.1..5): one address
// may hold at most 4 connections (max_clients_per_address).
#include <modbus.h>

#include <atomic>
#include <map>
#include <mutex>
#include <regex>
#include <set>
#include <thread>

#include "tests/support/modbus_cell.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;
using Clock = std::chrono::steady_clock;

constexpr auto kSoakDuration = 60s;
constexpr auto kTriggerPeriod = 100ms;  // 10 Hz
constexpr const char* kFrom[] = {"127.0.0.1", "127.0.0.2", "127.0.0.3", "127.0.0.4", "127.0.0.5"};

struct RobotLog {
  std::string endpoint;
  std::vector<std::uint32_t> cycles;  // cycle ids of result replies, in order
  int replies = 0, malformed = 0, notReady = 0, errors = 0;
  std::vector<std::string> bad;  // first malformed replies
};

void robotLoop(bool ur, const char* from, const std::atomic<bool>& stop, RobotLog& log) {
  log.endpoint = ur ? "ur" : "abb";
  // Reads wait up to 5 s, as the robot programs' socket timeouts.
  vgr::test::RawTcpClient robot(ur ? 50010 : 50011, {.from = from, .readTimeout = 5s, .throwOnFailure = false});
  if (!robot.connected()) {
    log.errors++;
    return;
  }
  const std::regex urRe(R"(\((-?\d+),(\d+)(,-?\d+\.\d{6}){6}\))");
  const std::regex abbRe(R"((-?\d+),(\d+)(,-?\d+\.\d{3}){6})");
  const std::string request = ur ? "GET,1\n" : "GET,1#";
  while (!stop) {
    if (!robot.send(request)) {
      log.errors++;
      break;
    }
    // URScript reads one parenthesised tuple; RAPID SocketReceive \Str one read of at most 80 characters.
    const std::string reply = (ur ? robot.readUntil(')') : robot.readOnce(80)).value_or("");
    if (reply.empty()) {
      log.errors++;
      break;
    }
    log.replies++;
    std::smatch m;
    if (!std::regex_match(reply, m, ur ? urRe : abbRe)) {
      log.malformed++;
      if (log.bad.size() < 3) log.bad.push_back(reply);
      continue;
    }
    const int status = std::stoi(m[1]);
    const auto cycle = static_cast<std::uint32_t>(std::stoul(m[2]));
    if (status == 2 || status == 3) {  // RESULT_NOT_READY / NO_NEW_TRIGGER at the deadline
      log.notReady++;
      continue;
    }
    log.cycles.push_back(cycle);
  }
}

struct PlcLog {
  std::vector<std::uint32_t> resultIds;  // one per trigger
  std::vector<int> codes;
  int triggers = 0, timeouts = 0, ioErrors = 0;
  double maxMs = 0;
};

void plcLoop(PlcLog& log) {
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", 1502);
  modbus_set_response_timeout(ctx, 1, 0);
  if (modbus_connect(ctx) != 0) {
    log.ioErrors++;
    modbus_free(ctx);
    return;
  }
  std::uint16_t counter = 0;
  modbus_read_registers(ctx, 2, 1, &counter);  // continue from the current TRIGGER_ID
  const auto end = Clock::now() + kSoakDuration;
  auto next = Clock::now();
  while (Clock::now() < end) {
    std::this_thread::sleep_until(next);
    next += kTriggerPeriod;
    counter = static_cast<std::uint16_t>(counter == 0xFFFF ? 1 : counter + 1);
    const auto t0 = Clock::now();
    if (modbus_write_register(ctx, 2, counter) != 1) {
      log.ioErrors++;
      continue;
    }
    log.triggers++;
    std::uint16_t acq = 0;
    modbus_read_input_registers(ctx, 18, 1, &acq);
    std::array<std::uint16_t, 4> r{};
    bool valid = false;
    while (Clock::now() - t0 < 3s) {
      if (modbus_read_input_registers(ctx, 16, 4, r.data()) != 4) {
        log.ioErrors++;
        break;
      }
      if ((r[0] & 0x08) && !(r[0] & 0x04) && r[3] == acq) {
        valid = true;
        break;
      }
      std::this_thread::sleep_for(1ms);
    }
    if (!valid) {
      log.timeouts++;
      continue;
    }
    log.maxMs = std::max(log.maxMs, std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
    log.resultIds.push_back(r[3]);
    log.codes.push_back(static_cast<std::int16_t>(r[1]));
  }
  modbus_close(ctx);
  modbus_free(ctx);
}

using soak_cell = ModbusCell;

TEST_F(soak_cell, TenRobotsAndA10HzPlcForAMinute) {
  ASSERT_NO_FATAL_FAILURE(startCell());
  std::atomic<bool> stop{false};
  std::vector<RobotLog> robots(10);
  std::vector<std::thread> threads;
  for (std::size_t i = 0; i < robots.size(); ++i)
    threads.emplace_back([&, i] { robotLoop(i < 5, kFrom[i % 5], stop, robots[i]); });
  std::this_thread::sleep_for(200ms);  // every robot is waiting before the first trigger
  PlcLog plc;
  plcLoop(plc);
  std::this_thread::sleep_for(300ms);  // the last result reaches the robots
  stop = true;
  for (auto& t : threads) t.join();  // each returns after its pending GET is answered (<= 1.5 s)

  // Stop vgrd so every journal line is on disk.
  ASSERT_EQ(vgrd_->stop(10000ms), 0) << log("vgrd.log");

  // PLC: one RESULT_VALID per trigger, distinct ids, all OK.
  EXPECT_GE(plc.triggers, 590);
  EXPECT_EQ(plc.timeouts, 0);
  EXPECT_EQ(plc.ioErrors, 0);
  ASSERT_EQ(plc.resultIds.size(), static_cast<std::size_t>(plc.triggers));
  const std::set<std::uint32_t> plcIds(plc.resultIds.begin(), plc.resultIds.end());
  EXPECT_EQ(plcIds.size(), plc.resultIds.size()) << "a RESULT_ID repeated";
  const auto okCount = std::count(plc.codes.begin(), plc.codes.end(), 0);
  EXPECT_EQ(okCount, plc.triggers) << "lost cycles (status != OK)";

  // Journal: exactly one line per trigger, the same cycles (ids stay below 65536 here).
  std::multiset<std::uint32_t> journalIds;
  for (const auto& j : journal()) journalIds.insert(j["cycle"].get<std::uint32_t>());
  EXPECT_EQ(journalIds.size(), static_cast<std::size_t>(plc.triggers));
  EXPECT_EQ(std::set<std::uint32_t>(journalIds.begin(), journalIds.end()), plcIds);

  // Robots.
  std::map<std::string, std::set<std::uint32_t>> perEndpoint;
  std::map<std::string, int> sharedDeliveries;  // cycles delivered to more than one client of an endpoint
  std::map<std::string, std::map<std::uint32_t, int>> deliveries;
  for (std::size_t i = 0; i < robots.size(); ++i) {
    const auto& r = robots[i];
    EXPECT_EQ(r.malformed, 0) << "client " << i << " (" << r.endpoint << "): " << (r.bad.empty() ? "" : r.bad.front());
    EXPECT_EQ(r.errors, 0) << "client " << i;
    EXPECT_GT(r.cycles.size(), 0u) << "client " << i;
    const std::set<std::uint32_t> unique(r.cycles.begin(), r.cycles.end());
    EXPECT_EQ(unique.size(), r.cycles.size()) << "client " << i << " (" << r.endpoint << ") saw a cycle twice";
    EXPECT_TRUE(std::is_sorted(r.cycles.begin(), r.cycles.end())) << "client " << i << " went back in time";
    for (const auto c : r.cycles) {
      EXPECT_TRUE(journalIds.contains(c)) << "client " << i << " got cycle " << c << " not in the journal";
      perEndpoint[r.endpoint].insert(c);
      deliveries[r.endpoint][c]++;
    }
  }
  for (const auto& [ep, cycles] : perEndpoint) {
    EXPECT_EQ(cycles, plcIds) << ep << ": " << cycles.size() << " of " << plcIds.size() << " cycles reached a client";
    for (const auto& [c, n] : deliveries[ep]) sharedDeliveries[ep] += n > 1 ? 1 : 0;
  }
  std::string summary;
  for (std::size_t i = 0; i < robots.size(); ++i)
    summary += robots[i].endpoint + ":" + std::to_string(robots[i].cycles.size()) + "/" + std::to_string(robots[i].replies) + " ";
  std::cout << "soak: " << plc.triggers << " triggers, max trigger->RESULT_VALID " << plc.maxMs << " ms; per client results/replies: "
            << summary << "; cycles delivered to >1 client: ur " << sharedDeliveries["ur"] << ", abb " << sharedDeliveries["abb"]
            << std::endl;
}

}  // namespace
