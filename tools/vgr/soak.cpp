#include "tools/vgr/soak.hpp"

#include <signal.h>
#include <unistd.h>

#include <algorithm>
#include <atomic>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <memory>
#include <mutex>
#include <random>
#include <sstream>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "config/cell_config.hpp"
#include "core/child_process.hpp"
#include "tools/vgr/notify_listener.hpp"
#include "tools/vgr/soak_actors.hpp"
#include "tools/vgr/soak_check.hpp"

namespace vgr::tools {

namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;
using soak::Clock;
using soak::wallNow;

// The fault kinds, in the order the schedule cycles through them.
const std::vector<std::string> kFaultKinds = {"camera_kill",     "camera_freeze",    "gvsp_loss",
                                              "robot_drop",      "robot_stall",      "plc_disconnect",
                                              "malformed_modbus", "malformed_robot", "vgrd_kill"};
constexpr int kBinaryPort = 50013, kStrictPort = 50014;
constexpr auto kRestartSec = 2s;          // systemd/vgrd.service RestartSec
constexpr auto kStartTimeout = 60s;       // systemd/vgrd.service TimeoutStartSec
constexpr auto kRssPeriod = 5s;

std::string selfDir() {
  std::error_code ec;
  const auto p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : p.parent_path().string();
}

long rssKb(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/status");
  for (std::string line; std::getline(in, line);)
    if (line.rfind("VmRSS:", 0) == 0) return std::stol(line.substr(6));
  return -1;
}

// User + system CPU seconds of a running process.
double cpuSeconds(pid_t pid) {
  std::ifstream in("/proc/" + std::to_string(pid) + "/stat");
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  const auto close = text.rfind(')');
  if (close == std::string::npos) return 0;
  std::istringstream rest(text.substr(close + 2));
  std::string field;
  double utime = 0, stime = 0;
  for (int i = 3; i <= 15 && rest >> field; ++i) {
    if (i == 14) utime = std::stod(field);
    if (i == 15) stime = std::stod(field);
  }
  return (utime + stime) / static_cast<double>(::sysconf(_SC_CLK_TCK));
}

std::string loadAverage() {
  std::ifstream in("/proc/loadavg");
  std::string a, b, c;
  in >> a >> b >> c;
  return a + " " + b + " " + c;
}

// The example cell, made for the soak: every dialect (binary and strict endpoints added),
// control only from 127.0.0.1 (so the attacker at 127.0.0.2 is read-only), a journal that
// rotates every 256 KiB and keeps every file for the checker.
Result<std::string> writeSoakCell(const std::string& dir) {
  YAML::Node root = YAML::Load(config::embeddedSimCellYaml());
  root["cell"]["journal_max_bytes"] = 262144;
  root["cell"]["journal_files"] = 1000;
  root["modbus"]["control_clients"].push_back("127.0.0.1");
  for (auto robot : root["robots"]) robot["control_clients"].push_back("127.0.0.1");
  YAML::Node binary;
  binary["name"] = "binary";
  binary["dialect"] = "binary";
  binary["bind"] = "127.0.0.1";
  binary["port"] = kBinaryPort;
  binary["reply_deadline_ms"] = 1500;
  binary["control_clients"].push_back("127.0.0.1");
  root["robots"].push_back(binary);
  YAML::Node strict;
  strict["name"] = "strict";
  strict["dialect"] = "strict";
  strict["bind"] = "127.0.0.1";
  strict["port"] = kStrictPort;
  strict["reply_deadline_ms"] = 1500;
  strict["max_clients"] = 1;
  root["robots"].push_back(strict);
  YAML::Emitter out;
  out << root;
  return config::writeSimCell(dir, std::string(out.c_str()) + "\n");
}

// vgrd as systemd runs it: started with NOTIFY_SOCKET, ready at READY=1, restarted 2 s
// after it died (our kill -9, or a crash), its RSS sampled. Its own thread.
class Supervisor {
 public:
  struct Incarnation {
    double readyWall = 0;
    std::vector<std::pair<double, long>> rss;  // (wall s, kB)
    double cpuS = 0;                            // CPU seconds when it ended
  };

  Supervisor(std::vector<std::string> argv, std::string logPath, std::string notifyPath, soak::CellState& cell)
      : argv_(std::move(argv)), log_(std::move(logPath)), notify_(std::move(notifyPath)), cell_(cell) {}
  ~Supervisor() { stop(); }

  bool startFirst() { return launch(); }
  void startThread() { thread_ = std::thread([this] { run(); }); }
  void requestKill() { killRequested_ = true; }
  void stop() {
    done_ = true;
    if (thread_.joinable()) thread_.join();
    if (vgrd_ && vgrd_->running()) {
      if (!incarnations_.empty()) incarnations_.back().cpuS = cpuSeconds(vgrd_->pid());
      vgrd_->stop();
    }
  }
  const std::vector<double>& kills() const { return kills_; }
  const std::vector<Incarnation>& incarnations() const { return incarnations_; }
  int crashes() const { return crashes_; }
  int failedStarts() const { return failedStarts_; }

 private:
  bool launch() {
    NotifyListener notify(notify_);
    ::setenv("NOTIFY_SOCKET", notify_.c_str(), 1);
    auto p = ChildProcess::spawn(argv_, log_);
    ::unsetenv("NOTIFY_SOCKET");
    if (!p || !notify.ok()) return false;
    vgrd_ = std::make_unique<ChildProcess>(std::move(*p));
    if (!notify.waitFor("READY=1", kStartTimeout, *vgrd_)) return false;
    incarnations_.push_back({wallNow(), {}, 0});
    lastRss_ = Clock::now() - kRssPeriod;
    cell_.vgrdUp = true;
    return true;
  }

  void down() {
    cell_.vgrdUp = false;
    cell_.incarnation.fetch_add(1);
  }

  void restart() {
    std::this_thread::sleep_for(kRestartSec);
    while (!done_ && !launch()) {
      ++failedStarts_;
      if (vgrd_) vgrd_->kill9();
      std::this_thread::sleep_for(kRestartSec);
    }
  }

  void run() {
    while (!done_) {
      std::this_thread::sleep_for(50ms);
      if (killRequested_.exchange(false) && vgrd_ && vgrd_->running()) {
        if (!incarnations_.empty()) incarnations_.back().cpuS = cpuSeconds(vgrd_->pid());
        kills_.push_back(wallNow());
        vgrd_->kill9();
        down();
        restart();
        continue;
      }
      if (vgrd_ && !vgrd_->running()) {  // died by itself: a crash, restarted as systemd would
        ++crashes_;
        kills_.push_back(wallNow());
        down();
        restart();
        continue;
      }
      if (vgrd_ && Clock::now() - lastRss_ >= kRssPeriod) {
        lastRss_ = Clock::now();
        if (const long kb = rssKb(vgrd_->pid()); kb > 0) incarnations_.back().rss.emplace_back(wallNow(), kb);
      }
    }
  }

  std::vector<std::string> argv_;
  std::string log_, notify_;
  soak::CellState& cell_;
  std::unique_ptr<ChildProcess> vgrd_;
  std::thread thread_;
  std::atomic<bool> killRequested_{false}, done_{false};
  std::vector<double> kills_;
  std::vector<Incarnation> incarnations_;
  Clock::time_point lastRss_{};
  int crashes_ = 0, failedStarts_ = 0;
};

// The camera emulator, restartable; faults on it are serialised by its mutex.
class Camera {
 public:
  Camera(std::vector<std::string> argv, std::string log) : argv_(std::move(argv)), log_(std::move(log)) {}
  bool start() {
    auto p = ChildProcess::spawn(argv_, log_);
    if (!p || !p->waitForLine("\"ready\"", 5000ms)) return false;
    proc_ = std::make_unique<ChildProcess>(std::move(*p));
    return true;
  }
  std::mutex& mutex() { return mutex_; }
  pid_t pid() const { return proc_ ? proc_->pid() : -1; }
  void kill9() {
    if (proc_) proc_->kill9();
  }
  void stop() {
    if (proc_) {
      ::kill(proc_->pid(), SIGCONT);
      proc_->stop();
    }
  }

 private:
  std::vector<std::string> argv_;
  std::string log_;
  std::unique_ptr<ChildProcess> proc_;
  std::mutex mutex_;
};

struct PlannedFault {
  double atS;  // since the start of the run
  std::string kind;
};

std::vector<PlannedFault> planFaults(const SoakOptions& o, const std::vector<std::string>& kinds, double horizonS) {
  std::vector<PlannedFault> plan;
  if (o.faults == "none" || kinds.empty()) return plan;
  std::mt19937_64 rng(o.seed);
  if (o.faults == "schedule") {
    std::size_t i = 0;
    for (double t = o.warmupS; t < horizonS; t += o.faultEveryS) plan.push_back({t, kinds[i++ % kinds.size()]});
    return plan;
  }
  // random: exponential spacing; vgrd kills on their own clock when killEveryS is set.
  const bool ownKillClock = o.killEveryS > 0 && std::find(kinds.begin(), kinds.end(), "vgrd_kill") != kinds.end();
  std::vector<std::string> others;
  for (const auto& k : kinds)
    if (!(ownKillClock && k == "vgrd_kill")) others.push_back(k);
  std::exponential_distribution<double> gap(1.0 / o.faultEveryS);
  std::uniform_int_distribution<std::size_t> pick(0, others.empty() ? 0 : others.size() - 1);
  for (double t = o.warmupS + gap(rng); !others.empty() && t < horizonS; t += gap(rng)) plan.push_back({t, others[pick(rng)]});
  if (ownKillClock) {
    std::exponential_distribution<double> killGap(1.0 / o.killEveryS);
    for (double t = o.warmupS + killGap(rng); t < horizonS; t += killGap(rng)) plan.push_back({t, "vgrd_kill"});
  }
  std::sort(plan.begin(), plan.end(), [](const PlannedFault& a, const PlannedFault& b) { return a.atS < b.atS; });
  return plan;
}

}  // namespace

int runSoak(const SoakOptions& o) {
  if (o.triggers <= 0 && o.durationS <= 0) return badInput("vgr soak: give --triggers or --duration-s");
  if (!(o.rateHz > 0 && o.rateHz <= 50)) return badInput("vgr soak: --rate-hz must be in (0, 50]");
  if (o.faults != "schedule" && o.faults != "random" && o.faults != "none")
    return badInput("vgr soak: --faults is schedule, random or none");
  std::vector<std::string> kinds;
  if (o.kinds.empty()) {
    kinds = kFaultKinds;
  } else {
    std::stringstream in(o.kinds);
    for (std::string k; std::getline(in, k, ',');) {
      if (std::find(kFaultKinds.begin(), kFaultKinds.end(), k) == kFaultKinds.end())
        return badInput("vgr soak: unknown fault kind '" + k + "'");
      kinds.push_back(k);
    }
  }
  const std::string bin = o.binDir.empty() ? selfDir() : o.binDir;
  std::string work = o.workDir;
  if (work.empty()) {
    char tmpl[] = "/tmp/vgr-soak-XXXXXX";
    if (!::mkdtemp(tmpl)) return badInput("vgr soak: cannot create a folder under /tmp");
    work = tmpl;
  }
  fs::create_directories(work);
  const auto cfgPath = writeSoakCell(work);
  if (!cfgPath) return badInput("vgr soak: " + cfgPath.error().message);
  const auto cfg = config::loadCellConfig(*cfgPath);
  if (!cfg) return badInput("vgr soak: " + cfg.error().message);
  const std::string journal = work + "/journal.jsonl";
  std::printf("vgr soak: %s; logs, journal and config in %s\n",
              o.triggers > 0 ? fmt::format("{} triggers", o.triggers).c_str() : fmt::format("{:.0f} s", o.durationS).c_str(),
              work.c_str());
  std::fflush(stdout);
  const std::string loadStart = loadAverage();
  const double wallStart = wallNow();

  Camera camera({bin + "/vgr-sim-camera", "--config", *cfgPath, "--loss", "0", "--loss-burst", fmt::format("{}", o.lossBurst)},
                work + "/camera.log");
  if (!camera.start()) {
    std::fprintf(stderr, "vgr soak: the camera emulator did not start (%s/camera.log)\n", work.c_str());
    return 2;
  }
  soak::CellState cell;
  Supervisor vgrd({bin + "/vgrd", "--config", *cfgPath, "--journal", journal}, work + "/vgrd.log", work + "/notify.sock",
                  cell);
  if (!vgrd.startFirst()) {
    std::fprintf(stderr, "vgr soak: vgrd did not become ready (%s/vgrd.log)\n", work.c_str());
    camera.stop();
    return 2;
  }
  vgrd.startThread();

  soak::PlcOptions plcOptions;
  plcOptions.port = cfg->modbus.port;
  plcOptions.job = cfg->jobs.front().id;
  plcOptions.rateHz = o.rateHz;
  plcOptions.stepTimeoutMs = cfg->cycleDeadlineMs + 1500;
  plcOptions.maxTriggers = o.triggers;
  soak::PlcActor plc(plcOptions, cell);
  std::vector<std::unique_ptr<soak::RobotActor>> robots;
  for (const auto& r : cfg->robots) {
    soak::RobotOptions ro;
    ro.name = r.name;
    ro.dialect = r.dialect;
    ro.port = r.port;
    ro.job = cfg->jobs.front().id;
    ro.replyTimeoutMs = r.replyDeadlineMs + 1500;
    robots.push_back(std::make_unique<soak::RobotActor>(ro, cell));
  }
  for (auto& r : robots) r->start();
  plc.start();

  // Faults, on the main thread's clock; each runs on a thread of its own so they overlap.
  // Faults are planned up to the duration, or twice the time the triggers take at the rate
  // (vgrd restarts and camera faults slow the PLC down).
  const double horizon = o.durationS > 0 ? o.durationS : static_cast<double>(o.triggers) / o.rateHz * 2.0 + 600.0;
  const auto plan = planFaults(o, kinds, horizon);
  std::map<std::string, int> injected;
  soak::AttackOutcome attacks;
  std::mutex attackMutex;
  std::vector<std::thread> faultThreads;
  std::mt19937_64 rng(o.seed ^ 0x5eed);
  std::size_t nextFault = 0, robotTurn = 0;
  std::vector<soak::RobotActor*> pollers;
  for (auto& r : robots)
    if (r->options().dialect != protocol::Dialect::Strict) pollers.push_back(r.get());
  const auto t0 = Clock::now();
  auto elapsed = [&] { return std::chrono::duration<double>(Clock::now() - t0).count(); };
  while (true) {
    if (o.durationS > 0 && elapsed() >= o.durationS) break;
    if (o.triggers > 0 && plc.triggers() >= o.triggers) break;
    while (nextFault < plan.size() && plan[nextFault].atS <= elapsed()) {
      const std::string kind = plan[nextFault++].kind;
      ++injected[kind];
      const double a = std::uniform_real_distribution<double>(1.0, 3.0)(rng);
      if (kind == "camera_kill") {
        faultThreads.emplace_back([&camera, a] {
          std::lock_guard lock(camera.mutex());
          camera.kill9();
          std::this_thread::sleep_for(std::chrono::duration<double>(a));
          for (int i = 0; i < 5 && !camera.start(); ++i) std::this_thread::sleep_for(500ms);
        });
      } else if (kind == "camera_freeze") {
        faultThreads.emplace_back([&camera, a] {
          std::lock_guard lock(camera.mutex());
          ::kill(camera.pid(), SIGSTOP);
          std::this_thread::sleep_for(std::chrono::duration<double>(a));
          ::kill(camera.pid(), SIGCONT);
        });
      } else if (kind == "gvsp_loss") {
        faultThreads.emplace_back([&camera, a] {
          std::lock_guard lock(camera.mutex());
          ::kill(camera.pid(), SIGUSR2);
          std::this_thread::sleep_for(std::chrono::duration<double>(a + 1.0));
          ::kill(camera.pid(), SIGUSR2);
        });
      } else if (kind == "robot_drop") {
        pollers[robotTurn++ % pollers.size()]->requestDrop();
      } else if (kind == "robot_stall") {
        pollers[robotTurn++ % pollers.size()]->requestStall();
      } else if (kind == "plc_disconnect") {
        plc.requestDisconnect();
      } else if (kind == "malformed_modbus") {
        faultThreads.emplace_back([&, port = cfg->modbus.port] {
          const soak::AttackOutcome a1 = soak::modbusGarbageBurst(port);
          std::lock_guard lock(attackMutex);
          attacks.frames += a1.frames;
          attacks.exceptions += a1.exceptions;
          attacks.served += a1.served;
          attacks.dropped += a1.dropped;
          attacks.unanswered += a1.unanswered;
        });
      } else if (kind == "malformed_robot") {
        for (auto* r : pollers) r->requestMalformed();
      } else if (kind == "vgrd_kill") {
        vgrd.requestKill();
      }
    }
    std::this_thread::sleep_for(20ms);
  }
  // The PLC finishes the trigger in flight and starts no other; the robots get the last
  // result; then everything stops.
  cell.draining = true;
  plc.stop();
  std::this_thread::sleep_for(std::chrono::milliseconds(1000));
  cell.stop = true;
  for (auto& r : robots) r->stop();
  for (auto& t : faultThreads) t.join();
  vgrd.stop();
  camera.stop();
  const double wallEnd = wallNow();

  // The verdict.
  soak::CheckInput in;
  int unparsable = 0, journalFiles = 0;
  in.journal = soak::readJournals(journal, unparsable, journalFiles);
  in.plc = plc.records();
  for (auto& r : robots) in.robots.push_back({r->options(), r->records()});
  in.kills = vgrd.kills();
  in.lateHandOverMs = soak::readLateHandOvers(work + "/vgrd.log");
  in.pauses = soak::readPauses(work + "/vgrd.log");
  in.cycleDeadlineMs = cfg->cycleDeadlineMs;
  in.replyDeadlineMs = cfg->robots.front().replyDeadlineMs;
  in.slackMs = o.slackMs;
  in.allowLateTyped = o.allowLateTyped;
  soak::CheckResult result = soak::check(in);
  int tornFiles = 0;
  for (const auto& e : fs::directory_iterator(work))
    if (e.path().filename().string().find("journal.jsonl.torn-") == 0) ++tornFiles;

  // RSS: of the longest-lived vgrd, first sample after the warm-up vs its last sample.
  const auto& incs = vgrd.incarnations();
  const Supervisor::Incarnation* longest = nullptr;
  for (const auto& inc : incs)
    if (!inc.rss.empty() && (!longest || inc.rss.back().first - inc.readyWall > longest->rss.back().first - longest->readyWall))
      longest = &inc;
  long rssStart = 0, rssEnd = 0, rssMax = 0;
  double rssSpanS = 0;
  if (longest) {
    for (const auto& [t, kb] : longest->rss) {
      if (rssStart == 0 && t - longest->readyWall >= o.warmupS) rssStart = kb;
      rssMax = std::max(rssMax, kb);
    }
    if (rssStart == 0) rssStart = longest->rss.front().second;
    rssEnd = longest->rss.back().second;
    rssSpanS = longest->rss.back().first - longest->readyWall;
  }
  double cpu = 0;
  for (const auto& inc : incs) cpu += inc.cpuS;

  nlohmann::ordered_json faults = nlohmann::ordered_json::object();
  for (const auto& k : kFaultKinds) faults[k] = injected.count(k) ? injected[k] : 0;
  auto& s = result.summary;
  s["faults"] = faults;
  s["rss_start_kb"] = rssStart;
  s["rss_end_kb"] = rssEnd;
  s["rss_max_kb"] = rssMax;
  s["rss_span_s"] = std::round(rssSpanS);
  s["vgrd"] = {{"restarts", static_cast<int>(incs.size()) - 1},
               {"crashes", vgrd.crashes()},
               {"failed_starts", vgrd.failedStarts()},
               {"cpu_s", std::round(cpu * 10) / 10}};
  s["malformed_modbus"] = {{"frames", attacks.frames},
                           {"exceptions", attacks.exceptions},
                           {"served", attacks.served},
                           {"dropped", attacks.dropped},
                           {"unanswered", attacks.unanswered}};
  s["journal"]["files"] = journalFiles;
  s["journal"]["unparsable_lines"] = unparsable;
  s["journal"]["torn_files"] = tornFiles;
  s["wall_s"] = std::round(wallEnd - wallStart);
  s["load_start"] = loadStart;
  s["load_end"] = loadAverage();
  s["seed"] = o.seed;
  const bool pass = result.pass && vgrd.crashes() == 0 && attacks.unanswered == 0 && unparsable == 0;
  s["pass"] = pass;
  for (const auto& p : result.problems) std::printf("problem: %s\n", p.c_str());
  std::ofstream(work + "/summary.json") << s.dump(2) << "\n";
  std::printf("%s\n", s.dump().c_str());
  std::fflush(stdout);
  return pass ? 0 : 1;
}

CLI::App* SoakCommand::add(CLI::App& parent) {
  auto& o = options_;
  auto* cmd = parent.add_subcommand("soak", "fault-injection run of the simulated cell: every trigger checked (docs/robustness.md)");
  cmd->add_option("--triggers", o.triggers, "stop after this many PLC triggers (0: --duration-s decides)")
      ->check(CLI::Range(0LL, 100000000LL));
  cmd->add_option("--duration-s", o.durationS, "stop after this many seconds (0: --triggers decides)")
      ->check(CLI::Range(0.0, 1e7));
  cmd->add_option("--rate-hz", o.rateHz, "PLC triggers per second")->capture_default_str();
  cmd->add_option("--seed", o.seed, "seed of the random faults and their parameters")->capture_default_str();
  cmd->add_option("--faults", o.faults, "schedule (round robin over the kinds), random, none")->capture_default_str();
  cmd->add_option("--fault-every-s", o.faultEveryS, "spacing (schedule) or mean spacing (random) of faults, s")
      ->check(CLI::Range(0.5, 1e6))
      ->capture_default_str();
  cmd->add_option("--kill-every-s", o.killEveryS, "random: mean spacing of vgrd kills, s (0: like the other faults)")
      ->check(CLI::Range(0.0, 1e7));
  cmd->add_option("--kinds", o.kinds, "comma-separated fault kinds (default: all)");
  cmd->add_option("--warmup-s", o.warmupS, "no fault before this; RSS first taken after it, s")->check(CLI::Range(0.0, 3600.0));
  cmd->add_option("--slack-ms", o.slackMs, "measurement slack on every deadline, ms")->check(CLI::Range(0, 5000))->capture_default_str();
  cmd->add_flag("--allow-late-typed", o.allowLateTyped, "late answers carrying a typed error do not fail the run");
  cmd->add_option("--loss-burst", o.lossBurst, "GVSP packet loss during a loss burst")->check(CLI::Range(0.0, 1.0));
  cmd->add_option("--bin-dir", o.binDir, "folder of vgrd and vgr-sim-camera (default: next to vgr)");
  cmd->add_option("--work-dir", o.workDir, "folder for logs, journal and config (default: a new /tmp/vgr-soak-*)");
  return cmd;
}

}  // namespace vgr::tools
