// Inputs that change nothing (issue 19): the real vgrd of the sim cell under attack on each
// of its socket inputs — a robot port (UR dialect), the Modbus port and the web port —
// while a good client of that port measures its round trips (robot: JOB,1 answered at once;
// Modbus: an FC04 read of STATUS; web: GET /metrics on a keep-alive connection):
//   slowloris (clients from 19 addresses dribbling a request a byte at a time),
//   a connection storm (connect + close as fast as one thread can),
//   a 1 MB request without a line end,
//   10,000 pipelined requests (read back concurrently: all answered, in order),
//   more clients than allowed (100 held connections from 19 addresses).
// Each attack is answered or refused by the rules of its protocol; the good client, already
// connected, is served on, until the attack has ended, without one failure: its p99 during
// the attack's first second within 2x its idle p99 measured just before (idle taken as at least 1 ms: the scheduler quantum of this loaded 2-core machine;
// idle loopback round trips are ~0.1 ms). vgrd and the good client run SCHED_FIFO, the
// attackers at nice +10 (tests/support/processes.hpp): on this shared machine (load ~20)
// the other engineers' compilers otherwise make both p99s, idle and attacked, 5-70 ms of
// scheduler waits that say nothing about vgrd (measured even at nice -10); on its own IPC
// vgrd has the cores. After each attack a new client is answered within 2 s (before: a
// storm's ~3400 closed connections in the web and robot ports' listen backlogs, drained at
// 200 accepts/s, kept every new client waiting ~17 s). vgrd's RSS grows by less than 16 MB over all of
// it, and its connection log stays bounded (rate-limited: 20 lines per 10 s per server,
// the rest counted) although thousands of connections came and went.
// Figures: docs/robustness.md ("Inputs that change nothing").
#include <modbus.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cstdio>
#include <fstream>
#include <functional>
#include <memory>
#include <regex>
#include <string>
#include <thread>
#include <vector>

#include "tests/support/libmodbus_client.hpp"
#include "tests/support/processes.hpp"
#include "tests/support/raw_tcp_client.hpp"
#include "tests/support/sim_cell.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::TestSocket;
using Clock = std::chrono::steady_clock;

constexpr std::chrono::milliseconds kIdle{700}, kAttack{1000};
// A new client after an attack: connected and answered within this (a browser or a
// Prometheus scrape waits seconds; a listen backlog of a storm's leftovers took 17 s).
constexpr std::chrono::milliseconds kNewcomerDeadline{2000};

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[std::min(v.size() - 1, static_cast<std::size_t>(q * static_cast<double>(v.size())))];
}

long rssKb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

const char* fromAddress(int i) {
  static const std::vector<std::string> kAddresses = [] {
    std::vector<std::string> a;
    for (int k = 2; k <= 20; ++k) a.push_back("127.0.0." + std::to_string(k));
    return a;
  }();
  return kAddresses[static_cast<std::size_t>(i) % kAddresses.size()].c_str();
}

// The attackers' threads run at nice 10: a real attacker is another machine; here it shares
// two cores with vgrd and the good client, and its own CPU use must not be what is measured.
void attackerPriority() { vgr::test::setThreadNice(10); }

// A good client of one port: one round trip, its duration in ms (< 0: failed).
using Probe = std::function<double()>;

struct Samples {
  std::vector<double> ms;
  int failures = 0;
};

Samples sample(const Probe& probe, std::chrono::milliseconds duration) {
  Samples s;
  const auto end = Clock::now() + duration;
  while (Clock::now() < end) {
    const double ms = probe();
    if (ms < 0)
      ++s.failures;
    else
      s.ms.push_back(ms);
    std::this_thread::sleep_for(1ms);  // dense: a p99 of thousands, not of a few scheduler stalls
  }
  return s;
}

// One attack, run on threads of its own until stop.
struct Attack {
  std::string name;
  std::function<void(std::atomic<bool>& stop)> run;
  std::function<void()> verify;  // after it stopped: its own outcome (answered / refused)
};

class input_attacks : public vgr::test::SimCell {
 protected:
  struct Row {
    std::string port, attack;
    double idleP99, p99, maxMs;
    std::size_t n;
    int failures;
    double newcomerMs;  // < 0: not measured on this port
  };

  // Runs every attack against `port` while `probe` measures; records a row per attack.
  // `newcomer`: a client that connects after the attack (a browser opening the page, a
  // scrape), served within kNewcomerDeadline: what an attack leaves behind (a listen backlog
  // full of a storm's closed connections) must not keep anyone waiting.
  void attackPort(const std::string& portName, const Probe& probe, const std::vector<Attack>& attacks,
                  const Probe& newcomer = nullptr) {
    for (const Attack& a : attacks) {
      const Samples idle = sample(probe, kIdle);
      ASSERT_EQ(idle.failures, 0) << portName << " / before " << a.name << ": the good client fails without an attack";
      std::atomic<bool> stop{false}, ended{false};
      std::thread t([&] {
        attackerPriority();
        a.run(stop);
        ended = true;
      });
      std::this_thread::sleep_for(150ms);  // under way
      Samples during = sample(probe, kAttack);
      stop = true;
      // Some attacks end only when they have had all their replies (10,000 pipelined
      // requests: seconds at 2000/s): the good client is served on meanwhile, as a real one
      // would be (and does not sit idle past the web port's 10 s keep-alive timeout).
      for (int sinceStop = 0; !ended; ++sinceStop) {
        if (probe() < 0) ++during.failures;
        std::this_thread::sleep_for(sinceStop < 10 ? 1ms : 10ms);
      }
      t.join();
      if (a.verify) a.verify();
      double newcomerMs = -1;
      if (newcomer) {
        const double ms = newcomerMs = newcomer();
        EXPECT_GE(ms, 0) << portName << " / after " << a.name << ": a new client is not served";
        EXPECT_LT(ms, kNewcomerDeadline.count()) << portName << " / after " << a.name << ": a new client waits";
      }
      const double idleP99 = percentile(idle.ms, 0.99), p99 = percentile(during.ms, 0.99);
      const double maxMs = during.ms.empty() ? 0 : *std::max_element(during.ms.begin(), during.ms.end());
      rows_.push_back({portName, a.name, idleP99, p99, maxMs, during.ms.size(), during.failures, newcomerMs});
      EXPECT_EQ(during.failures, 0) << portName << " / " << a.name;
      EXPECT_GT(during.ms.size(), 50u) << portName << " / " << a.name;
      EXPECT_LE(p99, std::max(2.0 * idleP99, 1.0)) << portName << " / " << a.name << ": idle p99 " << idleP99;
    }
  }

  void printRows() const {
    std::printf("| port | attack | good client idle p99 ms | during p99 ms | during max ms | samples | failed | new client after, ms |\n");
    std::printf("|---|---|---|---|---|---|---|---|\n");
    for (const auto& r : rows_)
      std::printf("| %s | %s | %.3f | %.3f | %.3f | %zu | %d | %s |\n", r.port.c_str(), r.attack.c_str(), r.idleP99, r.p99,
                  r.maxMs, r.n, r.failures, r.newcomerMs < 0 ? "-" : std::to_string(r.newcomerMs).substr(0, 6).c_str());
  }

  std::vector<Row> rows_;
};

// Attacks shaped by a port's protocol.
struct PortAttacks {
  std::uint16_t port;
  std::string dribble;                             // a request that never completes
  std::string pipelineRequest;                     // one complete request
  std::function<std::size_t(const std::string&)> countReplies;  // complete replies in a byte stream
};

std::vector<Attack> attacksOn(const PortAttacks& p, std::atomic<long>& connectionsMade) {
  std::vector<Attack> out;
  out.push_back({"slowloris (19 addresses, a byte per 100 ms)",
                 [p, &connectionsMade](std::atomic<bool>& stop) {
                   std::vector<std::unique_ptr<TestSocket>> socks;
                   std::vector<std::size_t> at;
                   while (!stop) {
                     while (socks.size() < 40) {
                       socks.push_back(std::make_unique<TestSocket>(p.port, fromAddress(static_cast<int>(socks.size()))));
                       at.push_back(0);
                       ++connectionsMade;
                     }
                     for (std::size_t i = 0; i < socks.size(); ++i) {
                       if (!socks[i]->connected() || !socks[i]->send(p.dribble.substr(at[i] % p.dribble.size(), 1))) {
                         socks[i] = std::make_unique<TestSocket>(p.port, fromAddress(static_cast<int>(i)));
                         ++connectionsMade;
                         at[i] = 0;
                         continue;
                       }
                       ++at[i];
                     }
                     std::this_thread::sleep_for(100ms);
                   }
                 },
                 nullptr});
  out.push_back({"connection storm (connect + close)",
                 [p, &connectionsMade](std::atomic<bool>& stop) {
                   while (!stop) {
                     TestSocket s(p.port, "127.0.0.21");
                     ++connectionsMade;
                   }
                 },
                 nullptr});
  out.push_back({"1 MB without a line end",
                 [p, &connectionsMade](std::atomic<bool>& stop) {
                   TestSocket s(p.port, "127.0.0.22");
                   ++connectionsMade;
                   const std::string chunk(64 * 1024, 'A');
                   for (int i = 0; i < 16 && !stop; ++i)
                     if (!s.send(chunk)) break;  // the server may close on it: that is its answer
                   while (!stop) std::this_thread::sleep_for(20ms);
                 },
                 nullptr});
  auto replies = std::make_shared<std::atomic<std::size_t>>(0);
  out.push_back({"10,000 pipelined requests",
                 [p, replies, &connectionsMade](std::atomic<bool>& stop) {
                   TestSocket s(p.port, "127.0.0.1");
                   ++connectionsMade;
                   std::string burst;
                   for (int i = 0; i < 10000; ++i) burst += p.pipelineRequest;
                   std::string got;
                   std::thread reader([&] {
                     attackerPriority();
                     const auto end = Clock::now() + 30s;
                     while (p.countReplies(got) < 10000 && Clock::now() < end) got += s.recvSome(200ms);
                   });
                   (void)s.send(burst);
                   reader.join();
                   *replies = p.countReplies(got);
                   while (!stop) std::this_thread::sleep_for(20ms);
                 },
                 [replies] { EXPECT_EQ(replies->load(), 10000u) << "every pipelined request answered"; }});
  out.push_back({"more clients than allowed (100 held)",
                 [p, &connectionsMade](std::atomic<bool>& stop) {
                   std::vector<std::unique_ptr<TestSocket>> held;
                   for (int i = 0; i < 100 && !stop; ++i) {
                     held.push_back(std::make_unique<TestSocket>(p.port, fromAddress(i)));
                     ++connectionsMade;
                   }
                   while (!stop) std::this_thread::sleep_for(20ms);
                 },
                 nullptr});
  return out;
}

std::size_t countOccurrences(const std::string& s, const std::string& what) {
  std::size_t n = 0;
  for (std::size_t at = s.find(what); at != std::string::npos; at = s.find(what, at + what.size())) ++n;
  return n;
}

TEST_F(input_attacks, EverySocketInputServesItsGoodClientDuringEachAttack) {
  const int webPort = vgr::test::freeLoopbackPort();
  ASSERT_GT(webPort, 0);
  ASSERT_NO_FATAL_FAILURE(startCell([webPort](std::string yaml) {
    return yaml + "\nweb:\n  bind: 0.0.0.0\n  port: " + std::to_string(webPort) + "\n";
  }));
  // The sim cell binds 127.0.0.1; attackers come from other loopback addresses, which the
  // kernel routes to it.
  ASSERT_TRUE(vgr::test::setProcessRealtime(vgrd_->pid()));
  ASSERT_TRUE(vgr::test::setThreadRealtime());  // the good clients
  struct Normal {
    ~Normal() { vgr::test::setThreadNormal(); }
  } normalAgain;
  const long rssStart = rssKb(vgrd_->pid());
  std::atomic<long> connections{0};

  // Robot port (UR dialect): JOB,1 is answered at once (no result needed).
  TestSocket robot(kUrPort, "127.0.0.1");
  ASSERT_TRUE(robot.connected());
  const Probe robotProbe = [&] {
    const auto t0 = Clock::now();
    if (!robot.send("JOB,1\n")) return -1.0;
    if (robot.readUntil(')', 2000ms).rfind("(0,0,", 0) != 0) return -1.0;
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  };
  const std::regex urReply(R"(\(-?\d+,\d+(,-?\d+\.\d{6}){6}\))");
  PortAttacks robotAttacks{static_cast<std::uint16_t>(kUrPort), "GET,1", "JOB,1\n", [](const std::string& s) {
                             return static_cast<std::size_t>(std::count(s.begin(), s.end(), ')'));
                           }};
  // A new client after each attack (every port: from 127.0.0.30, an address no attack uses).
  const auto newcomer = [](int port, std::string request, std::function<bool(TestSocket&)> answered) -> Probe {
    return [port, request, answered] {
      const auto t0 = Clock::now();
      TestSocket fresh(static_cast<std::uint16_t>(port), "127.0.0.30");
      if (!fresh.connected() || !fresh.send(request) || !answered(fresh)) return -1.0;
      return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
    };
  };
  const Probe robotNewcomer = newcomer(kUrPort, "JOB,1\n", [](TestSocket& s) {
    return s.readUntil(')', 5000ms).rfind("(0,0,", 0) == 0;
  });
  ASSERT_NO_FATAL_FAILURE(attackPort("robot (ur)", robotProbe, attacksOn(robotAttacks, connections), robotNewcomer));

  // Modbus: FC04 read of STATUS.
  vgr::test::LibmodbusClient plc(static_cast<std::uint16_t>(kModbusPort));
  ASSERT_TRUE(plc.connected);
  const Probe modbusProbe = [&] {
    std::uint16_t status = 0;
    const auto t0 = Clock::now();
    if (plc.readStatus(status) != 1) return -1.0;
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  };
  const std::string readStatus("\x00\x01\x00\x00\x00\x06\x01\x04\x00\x10\x00\x01", 12);
  PortAttacks modbusAttacks{static_cast<std::uint16_t>(kModbusPort), readStatus.substr(0, 7), readStatus,
                            [](const std::string& s) { return s.size() / 11; }};
  const Probe modbusNewcomer = newcomer(kModbusPort, readStatus, [](TestSocket& s) {
    return s.readBytes(11, 5000ms).size() == 11;
  });
  ASSERT_NO_FATAL_FAILURE(attackPort("modbus", modbusProbe, attacksOn(modbusAttacks, connections), modbusNewcomer));

  // Web: GET /metrics on a keep-alive connection.
  TestSocket web(static_cast<std::uint16_t>(webPort), "127.0.0.1");
  ASSERT_TRUE(web.connected());
  const Probe webProbe = [&] {
    const auto t0 = Clock::now();
    if (!web.send("GET /metrics HTTP/1.1\r\nHost: vgrd\r\n\r\n")) return -1.0;
    std::string head;
    while (head.find("\r\n\r\n") == std::string::npos) {
      const std::string line = web.readUntil('\n', 2000ms);
      if (line.empty()) return -1.0;
      head += line;
    }
    std::smatch m;
    if (!std::regex_search(head, m, std::regex("Content-Length: (\\d+)", std::regex::icase))) return -1.0;
    if (web.readBytes(std::stoul(m[1]), 2000ms).size() != std::stoul(m[1])) return -1.0;
    return std::chrono::duration<double, std::milli>(Clock::now() - t0).count();
  };
  const std::string pipelined = "GET /nothing-here HTTP/1.1\r\nHost: vgrd\r\n\r\n";
  PortAttacks webAttacks{static_cast<std::uint16_t>(webPort), "GET /metrics HTTP/1.1\r\nX-Slow: ", pipelined,
                         [](const std::string& s) { return countOccurrences(s, "HTTP/1.1 404"); }};
  const Probe webNewcomer = newcomer(webPort, "GET /metrics HTTP/1.1\r\nHost: vgrd\r\nConnection: close\r\n\r\n",
                                     [](TestSocket& s) { return s.readUntil('\n', 5000ms).rfind("HTTP/1.1 200", 0) == 0; });
  ASSERT_NO_FATAL_FAILURE(attackPort("web", webProbe, attacksOn(webAttacks, connections), webNewcomer));

  printRows();
  const long rssEnd = rssKb(vgrd_->pid());
  std::printf("vgrd RSS %ld kB before the attacks, %ld kB after; %ld attacking connections\n", rssStart, rssEnd,
              connections.load());
  EXPECT_LT(rssEnd - rssStart, 16 * 1024) << "memory bounded";
  EXPECT_TRUE(vgrd_->running());

  // Issue 19, item 8: thousands of connections, a bounded log (before: two info lines per
  // connection, 12,000 connections made 2.6 MB).
  const std::string text = log("vgrd.log");
  const std::size_t lines = countOccurrences(text, " connected (") + countOccurrences(text, " disconnected");
  std::printf("connection log lines: %zu for %ld connections\n", lines, connections.load());
  EXPECT_GT(connections.load(), 2000);
  EXPECT_LT(lines, 400u);
  EXPECT_EQ(countOccurrences(text, "not in allowed_clients"), 0u) << "no list, no such message";
}

}  // namespace
