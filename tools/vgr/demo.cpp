#include "tools/vgr/demo.hpp"

#include <signal.h>
#include <sys/socket.h>
#include <sys/un.h>
#include <unistd.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <optional>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/format.h>
#include <nlohmann/json.hpp>
#include <yaml-cpp/yaml.h>

#include "config/cell_config.hpp"
#include "core/child_process.hpp"
#include "core/pose.hpp"
#include "sim/cell_scenes.hpp"
#include "sim/dataset.hpp"

namespace vgr::tools {
namespace fs = std::filesystem;
using nlohmann::json;
using std::chrono::milliseconds;

namespace {

std::string selfDir() {
  std::error_code ec;
  const auto p = fs::read_symlink("/proc/self/exe", ec);
  return ec ? std::string(".") : p.parent_path().string();
}

double percentile(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const double pos = q * static_cast<double>(v.size() - 1);
  const auto lo = static_cast<std::size_t>(std::floor(pos));
  const auto hi = std::min(lo + 1, v.size() - 1);
  return v[lo] + (pos - static_cast<double>(lo)) * (v[hi] - v[lo]);
}

double angleDiffDeg(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

double round3(double v) { return std::round(v * 1000.0) / 1000.0; }

// The rotation of a journal part (or a vgr-sim-robot line): rz_deg, ry_deg, rx_deg, Z-Y-X.
Pose journalRotation(const json& j) {
  return poseFromEulerZyxDeg(0, 0, 0, EulerZyxDeg{j.value("rz_deg", 0.0), j.value("ry_deg", 0.0), j.value("rx_deg", 0.0)});
}

// The angle of a^-1 b, degrees [0, 180].
double rotationDiffDeg(const Pose& a, const Pose& b) {
  const Pose d = compose(inverse(a), b);
  return 2.0 * std::acos(std::min(1.0, std::abs(d.qw))) * 180.0 / M_PI;
}

// A datagram socket standing in for systemd's NOTIFY_SOCKET: vgrd's READY=1 arrives here.
class NotifyListener {
 public:
  explicit NotifyListener(const std::string& path) : path_(path) {
    fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
    sockaddr_un sa{};
    sa.sun_family = AF_UNIX;
    std::snprintf(sa.sun_path, sizeof sa.sun_path, "%s", path.c_str());
    ::unlink(path.c_str());
    if (::bind(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
      ::close(fd_);
      fd_ = -1;
    }
  }
  ~NotifyListener() {
    if (fd_ >= 0) ::close(fd_);
    ::unlink(path_.c_str());
  }
  bool ok() const { return fd_ >= 0; }
  bool waitFor(const std::string& what, milliseconds timeout, ChildProcess& child) {
    const auto deadline = std::chrono::steady_clock::now() + timeout;
    while (std::chrono::steady_clock::now() < deadline) {
      if (!child.running()) return false;
      timeval tv{0, 100000};
      ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
      char buf[512];
      const ssize_t n = ::recv(fd_, buf, sizeof buf - 1, 0);
      if (n > 0 && std::string(buf, static_cast<std::size_t>(n)).find(what) != std::string::npos) return true;
    }
    return false;
  }

 private:
  std::string path_;
  int fd_ = -1;
};

struct RobotTally {
  int replies = 0, valid = 0, invalid = 0, ok = 0, mismatched = 0;
};

}  // namespace

// --method: teaches `method` on the template of the cell's textured part with `vgr teach`
// (work/job) and writes work/sim-cell-taught.yaml: the example with sim.scene `part` and its
// job 1 replaced by that folder, angle_offset_deg the base +x axis in the image (the
// template shows the part at rz = 0). Returns the config's path.
Result<std::string> teachDemoJob(config::CellConfig cell, const std::string& bin, const std::string& work,
                                 const std::string& method) {
  if (cell.sim.scene == "plate") cell.sim.scene = "part";
  const sim::CellScenes scenes(cell);
  fs::create_directories(work + "/teach");
  // template.png + template.yaml (grasp point, the levels' top faces with their heights).
  const auto t = sim::writePartTemplate(*scenes.partRenderer(), work + "/teach");
  if (!t) return std::unexpected(t.error());
  const std::string job = work + "/job";
  auto teach = ChildProcess::spawn({bin + "/vgr", "teach", "--image", work + "/teach/template.png", "--grasp",
                                    fmt::format("{:.3f},{:.3f}", t->graspU, t->graspV), "--regions",
                                    work + "/teach/template.yaml", "--method", method, "--part-height",
                                    fmt::format("{:.3f}", scenes.partRenderer()->part().graspHeightMm), "--out", job},
                                   work + "/teach/teach.log");
  if (!teach || teach->wait(milliseconds(60000)) != 0) {
    std::ifstream in(work + "/teach/teach.log");
    std::string log((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
    return fail(Status::BadArgument, "vgr teach --method " + method + " failed: " + log);
  }
  std::string yaml = config::embeddedSimCellYaml();
  const auto a = yaml.find("jobs:\n"), b = yaml.find("\n# Used by the simulators");
  const auto s = yaml.find("\nsim:\n");
  if (a == std::string::npos || b == std::string::npos || s == std::string::npos || !(a < b && b < s))
    return fail(Status::BadArgument, "the embedded sim-cell.yaml has no jobs/sim sections where expected");
  yaml.replace(s, 6, "\nsim:\n  scene: " + cell.sim.scene + "\n");
  YAML::Emitter jobs;  // the folder may hold any character: escaped by the emitter
  jobs << YAML::BeginMap << YAML::Key << "jobs" << YAML::Value << YAML::BeginSeq << YAML::BeginMap << YAML::Key << "id"
       << YAML::Value << 1 << YAML::Key << "name" << YAML::Value << "taught-" + method << YAML::Key << "folder"
       << YAML::Value << job << YAML::Key << "angle_offset_deg" << YAML::Value
       << fmt::format("{:.6f}", sim::baseXAxisImageAngleDeg(cell)) << YAML::EndMap << YAML::EndSeq << YAML::EndMap;
  yaml.replace(a, b - a, std::string(jobs.c_str()) + "\n");
  const std::string path = work + "/sim-cell-taught.yaml";
  std::ofstream(path) << yaml;
  std::printf("vgr demo: taught a job of method %s on the textured part (%s), config %s\n", method.c_str(), job.c_str(), path.c_str());
  return path;
}

// The last lines of the cell's log, so a failed start says why right away.
void printLogTail(const std::string& path, std::size_t lines = 6) {
  std::ifstream in(path);
  std::vector<std::string> all;
  for (std::string l; std::getline(in, l);) all.push_back(l);
  for (std::size_t i = all.size() > lines ? all.size() - lines : 0; i < all.size(); ++i)
    std::fprintf(stderr, "  | %s\n", all[i].c_str());
}

int runDemo(const DemoOptions& o) {
  // The cell: the embedded example unless told otherwise.
  auto cfg = o.configPath.empty() ? config::parseCellConfig(config::embeddedSimCellYaml(), "<embedded sim-cell.yaml>")
                                  : config::loadCellConfig(o.configPath);
  if (!cfg) {
    std::fprintf(stderr, "vgr demo: %s\n", cfg.error().message.c_str());
    return 2;
  }
  if (o.seed >= 0) cfg->sim.seed = static_cast<std::uint64_t>(o.seed);
  if (!o.scene.empty()) {
    if (o.method.empty() || (o.scene != "part" && o.scene != "multi")) {
      std::fprintf(stderr, "vgr demo: --scene part|multi goes with --method (the example's moments job is taught on the plate)\n");
      return 2;
    }
    cfg->sim.scene = o.scene;
  }
  if (!o.method.empty() && !o.configPath.empty()) {
    std::fprintf(stderr, "vgr demo: --method runs the embedded example cell; for your own config, teach a job with "
                         "`vgr teach` and name its folder in the config's jobs (docs/localization.md)\n");
    return 2;
  }
  const std::string bin = o.binDir.empty() ? selfDir() : o.binDir;
  std::string work = o.workDir;
  if (work.empty()) {
    char tmpl[] = "/tmp/vgr-demo-XXXXXX";
    if (!::mkdtemp(tmpl)) {
      std::perror("vgr demo: mkdtemp");
      return 2;
    }
    work = tmpl;
  }
  fs::create_directories(work);
  std::string configFile = o.configPath;
  if (configFile.empty()) {
    // The example and the calibration files it maps with (config/examples/sim-calib).
    auto written = config::writeSimCell(work);
    if (!written) {
      std::fprintf(stderr, "vgr demo: %s\n", written.error().message.c_str());
      return 2;
    }
    configFile = *written;
  }
  if (!o.method.empty()) {
    if (auto taught = teachDemoJob(*cfg, bin, work, o.method); !taught) {
      std::fprintf(stderr, "vgr demo: %s\n", taught.error().message.c_str());
      return 2;
    } else {
      configFile = *taught;
      cfg = config::loadCellConfig(configFile);
      if (!cfg) {
        std::fprintf(stderr, "vgr demo: %s\n", cfg.error().message.c_str());
        return 2;
      }
    }
  }
  const std::string journal = work + "/journal.jsonl";
  const std::string logs = work + "/logs.txt";
  std::printf("vgr demo: %d cycles; logs, journal and ground truth in %s\n", o.cycles, work.c_str());
  std::fflush(stdout);

  // 1. The camera emulator.
  auto camera = ChildProcess::spawn({bin + "/vgr-sim-camera", "--config", configFile, "--seed", std::to_string(cfg->sim.seed),
                                     "--truth", work + "/truth.jsonl"},
                                    logs);
  if (!camera || !camera->waitForLine("\"ready\"", milliseconds(5000))) {
    std::fprintf(stderr, "vgr demo: the camera emulator did not start (see %s)\n", logs.c_str());
    printLogTail(logs);
    return 2;
  }

  // 2. vgrd, with our own NOTIFY_SOCKET standing in for systemd.
  NotifyListener notify(work + "/notify.sock");
  ::setenv("NOTIFY_SOCKET", (work + "/notify.sock").c_str(), 1);
  auto vgrd = ChildProcess::spawn({bin + "/vgrd", "--config", configFile, "--journal", journal}, logs);
  ::unsetenv("NOTIFY_SOCKET");
  if (!vgrd || !notify.ok() || !notify.waitFor("READY=1", milliseconds(15000), *vgrd)) {
    std::fprintf(stderr, "vgr demo: vgrd did not become ready (see %s)\n", logs.c_str());
    printLogTail(logs);
    return 2;
  }

  // 3. Robots polling, then the PLC triggering.
  std::map<std::string, ChildProcess> robots;
  for (const auto& r : cfg->robots) {
    if (r.dialect == config::Dialect::Strict) continue;  // a push protocol: not a poller
    const std::string dialect(config::dialectName(r.dialect));
    auto p = ChildProcess::spawn({bin + "/vgr-sim-robot", "--dialect", dialect, "--host", r.bind, "--port",
                                  std::to_string(r.port), "--job", std::to_string(cfg->jobs.front().id), "--count", "0",
                                  "--interval-ms", "0", "--name", r.name, "--json"},
                                 logs);
    if (!p) {
      std::fprintf(stderr, "vgr demo: cannot start vgr-sim-robot\n");
      return 2;
    }
    robots.emplace(r.name, std::move(*p));
  }
  auto plc = ChildProcess::spawn({bin + "/vgr-sim-plc", "--host", cfg->modbus.bind, "--port", std::to_string(cfg->modbus.port),
                                  "--cycles", std::to_string(o.cycles), "--job", std::to_string(cfg->jobs.front().id),
                                  "--interval-ms", std::to_string(o.intervalMs), "--json"},
                                 logs);
  if (!plc) {
    std::fprintf(stderr, "vgr demo: cannot start vgr-sim-plc\n");
    return 2;
  }

  std::vector<json> plcLines;
  std::map<std::string, std::vector<json>> robotLines;
  auto drainRobots = [&](milliseconds wait) {
    for (auto& [name, p] : robots)
      while (auto line = p.readLine(wait)) {
        try {
          robotLines[name].push_back(json::parse(*line));
        } catch (const json::exception&) {
          robotLines[name].push_back(json{{"valid", false}, {"raw", *line}});
        }
        wait = milliseconds(0);
      }
  };
  const auto plcDeadline = std::chrono::steady_clock::now() + milliseconds(o.cycles * (cfg->cycleDeadlineMs + o.intervalMs + 500) + 10000);
  while (std::chrono::steady_clock::now() < plcDeadline) {
    auto line = plc->readLine(milliseconds(20));
    drainRobots(milliseconds(0));
    if (line) {
      try {
        auto j = json::parse(*line);
        if (j.contains("n")) plcLines.push_back(j);
      } catch (const json::exception&) {
      }
      continue;
    }
    if (!plc->running()) {
      while (auto rest = plc->readLine(milliseconds(100))) {
        try {
          auto j = json::parse(*rest);
          if (j.contains("n")) plcLines.push_back(j);
        } catch (const json::exception&) {
        }
      }
      break;
    }
  }
  plc->stop();
  // Let the robots pick up the last result, then ask them for their summaries.
  drainRobots(milliseconds(300));
  for (auto& [name, p] : robots) ::kill(p.pid(), SIGTERM);
  drainRobots(milliseconds(1000));
  for (auto& [name, p] : robots) p.stop();
  vgrd->stop();
  camera->stop();

  // 4. Score against ground truth: journal gives cycle -> frame id, the renderer frame id -> pose.
  std::map<std::uint32_t, json> byCycle;
  {
    std::ifstream in(journal);
    std::string line;
    while (std::getline(in, line)) {
      try {
        auto j = json::parse(line);
        byCycle[j.at("cycle").get<std::uint32_t>() & 0xFFFFu] = j;
      } catch (const json::exception&) {
      }
    }
  }
  const sim::CellScenes scenes(*cfg);
  int ok = 0;
  double maxPos = 0, maxAng = 0;
  std::vector<double> latencies;
  for (const auto& p : plcLines) {
    const int n = p.value("n", 0);
    if (!p.contains("status") || !p["status"].is_number_integer()) {
      if (!o.quiet) std::printf("cycle %3d  no answer (%s)\n", n, p.value("step", std::string("?")).c_str());
      continue;
    }
    const int status = p["status"].get<int>();
    const double latency = p.value("latency_ms", 0.0);
    latencies.push_back(latency);
    const auto rid = p.value("result_id", 0u);
    auto jit = byCycle.find(rid & 0xFFFFu);
    if (status != 0 || jit == byCycle.end()) {
      if (!o.quiet) std::printf("cycle %3d  id %5u  status %d  latency %6.1f ms\n", n, rid, status, latency);
      continue;
    }
    const auto frameId = jit->second.value("frame_id", std::uint64_t{0});
    // The PLC gets the first part: score it against the nearest part of the frame.
    double pos = 1e9, ang = 180;
    for (const auto& t : scenes.truth(frameId)) {
      const double d = std::hypot(p.value("x", 0.0) - t.xMm, p.value("y", 0.0) - t.yMm);
      if (d < pos) {
        pos = d;
        ang = angleDiffDeg(p.value("r3", 0.0), t.rzDeg);
      }
    }
    maxPos = std::max(maxPos, pos);
    maxAng = std::max(maxAng, ang);
    ++ok;
    if (!o.quiet)
      std::printf("cycle %3d  id %5u  frame %5llu  x %8.3f  y %8.3f  rz %8.3f deg  err %.3f mm %.3f deg  latency %6.1f ms\n", n,
                  rid, static_cast<unsigned long long>(frameId), p.value("x", 0.0), p.value("y", 0.0), p.value("r3", 0.0),
                  pos, ang, latency);
  }

  // Robots: every reply well-formed, and every OK reply carries the journal's pose for its cycle.
  bool robotsOk = true;
  for (auto& [name, lines] : robotLines) {
    RobotTally t;
    for (const auto& j : lines) {
      if (j.contains("replies")) continue;  // the simulator's own summary
      ++t.replies;
      if (!j.value("valid", false)) {
        ++t.invalid;
        continue;
      }
      ++t.valid;
      if (j.value("status", -99) != 0) continue;
      ++t.ok;
      auto jit = byCycle.find(j.value("cycle", 0u) & 0xFFFFu);
      if (jit == byCycle.end() || jit->second["parts"].empty()) {
        ++t.mismatched;
        continue;
      }
      // All six degrees of freedom: the position, and the angle between the two rotations
      // (the robot's reply converted from its dialect's notation, the journal's Z-Y-X).
      const auto& part = jit->second["parts"][0];
      if (std::abs(part.value("x_mm", 0.0) - j.value("x_mm", 1e9)) > 0.01 ||
          std::abs(part.value("y_mm", 0.0) - j.value("y_mm", 1e9)) > 0.01 ||
          std::abs(part.value("z_mm", 0.0) - j.value("z_mm", 1e9)) > 0.01 ||
          rotationDiffDeg(journalRotation(part), journalRotation(j)) > 0.01)
        ++t.mismatched;
    }
    if (t.invalid || t.mismatched || t.ok == 0) robotsOk = false;
    std::printf("robot %s: %d replies, %d well-formed, %d malformed, %d with a pose, %d not matching the journal\n", name.c_str(),
                t.replies, t.valid, t.invalid, t.ok, t.mismatched);
  }

  const int lost = o.cycles - ok;
  nlohmann::ordered_json summary = {{"cycles", o.cycles},
                  {"ok", ok},
                  {"lost", lost},
                  {"max_pos_err_mm", round3(maxPos)},
                  {"max_angle_err_deg", round3(maxAng)},
                  {"p50_latency_ms", round3(percentile(latencies, 0.50))},
                  {"p99_latency_ms", round3(percentile(latencies, 0.99))}};
  std::printf("%s\n", summary.dump().c_str());
  std::fflush(stdout);
  return (lost == 0 && robotsOk) ? 0 : 1;
}

CLI::App* DemoCommand::add(CLI::App& parent) {
  auto& demo = options_;
  auto* demoCmd = parent.add_subcommand("demo", "run the simulated cell (camera emulator, vgrd, PLC and robot simulators) for N cycles");
  demoCmd->add_option("--cycles", demo.cycles, "number of PLC-triggered cycles")->check(CLI::Range(1, 1000000));
  demoCmd->add_option("--config", demo.configPath, "cell config (default: the embedded config/examples/sim-cell.yaml)");
  demoCmd->add_option("--bin-dir", demo.binDir, "folder of vgrd and the simulators (default: next to vgr)");
  demoCmd->add_option("--work-dir", demo.workDir, "folder for logs, journal and truth (default: a new /tmp/vgr-demo-*)");
  demoCmd->add_option("--interval-ms", demo.intervalMs, "PLC pause between cycles")->check(CLI::Range(0, 60000));
  demoCmd->add_option("--seed", demo.seed, "scene seed (default: the config's sim.seed)");
  demoCmd->add_flag("--quiet", demo.quiet, "only the summary lines");
  demoCmd->add_option("--scene", demo.scene, "with --method: part (textured plate, default) or multi (height levels)");
  demoCmd->add_option("--method", demo.method, "run a job of this method taught on the textured part (moments, hu, sift, orb-ransac, orb-prosac, orb-adk, contour-weighted, shape)");
  return demoCmd;
}

}  // namespace vgr::tools
