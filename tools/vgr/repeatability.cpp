#include "tools/vgr/repeatability.hpp"

#include <algorithm>
#include <array>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <thread>

#include <netdb.h>
#include <sys/socket.h>
#include <sys/time.h>
#include <unistd.h>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <modbus.h>
#include <nlohmann/json.hpp>

#include "config/cell_config.hpp"
#include "core/angles.hpp"
#include "daemon/cell_mapping.hpp"
#include "daemon/repeatability_record.hpp"
#include "protocol/modbus_map.hpp"
#include "tools/vgr/cell_frames.hpp"

namespace vgr::tools {
namespace {

using Clock = std::chrono::steady_clock;
constexpr const char* kAxes[6] = {"x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg"};

int bad(const std::string& msg) {
  std::fprintf(stderr, "vgr repeatability: %s\n", msg.c_str());
  return 2;
}

struct Shot {
  std::array<double, 6> v{};  // x, y, z mm; rx, ry, rz deg
};

struct Failure {
  int shot;
  std::string what;
};

// Live: the PLC's side of the counter-mode handshake (docs/protocols.md). Returns the shots
// that delivered a part, the failures (status, timeout) in `failures`.
Result<std::vector<Shot>> triggerLive(const config::CellConfig& cell, int job, int shots, int intervalMs,
                                      std::vector<Failure>& failures, bool progress) {
  if (!cell.modbus.enabled)
    return fail(Status::BadArgument, "live shots trigger vgrd over its Modbus server, and the config has modbus.enabled: false "
                                     "(record frames with vgr grab --save and pass --images)");
  const std::string host = cell.modbus.bind == "0.0.0.0" ? "127.0.0.1" : cell.modbus.bind;
  modbus_t* ctx = modbus_new_tcp(host.c_str(), cell.modbus.port);
  if (!ctx) return fail(Status::Internal, "modbus_new_tcp failed");
  struct Free {
    modbus_t* c;
    ~Free() {
      modbus_close(c);
      modbus_free(c);
    }
  } guard{ctx};
  if (modbus_connect(ctx) != 0)
    return fail(Status::BadArgument, fmt::format("cannot reach vgrd's Modbus server at {}:{}: {} (is vgrd running?)", host,
                                                 cell.modbus.port, modbus_strerror(errno)));
  modbus_set_response_timeout(ctx, 2, 0);
  using namespace protocol::modbus;  // register and bit names
  std::uint16_t regs[30] = {};
  auto read = [&] { return modbus_read_input_registers(ctx, 16, 30, regs) == 30; };
  // READY, the job, TRIGGER_ENABLE when the cell asks for it; counter mode from the current value.
  const auto readyBy = Clock::now() + std::chrono::seconds(10);
  while (read() && !(regs[0] & kStatusReady) && Clock::now() < readyBy) std::this_thread::sleep_for(std::chrono::milliseconds(20));
  if (!(regs[0] & kStatusReady)) return fail(Status::CameraError, "vgrd is not READY (camera not streaming?)");
  if (modbus_write_register(ctx, 1, static_cast<std::uint16_t>(job)) != 1 ||
      (cell.modbus.requireTriggerEnable && modbus_write_register(ctx, 0, 0x08) != 1))
    return fail(Status::Internal, fmt::format("writing JOB_ID: {}", modbus_strerror(errno)));
  std::uint16_t counter = 0;
  if (modbus_read_registers(ctx, 2, 1, &counter) != 1) return fail(Status::Internal, "reading TRIGGER_ID failed");
  const auto timeout = std::chrono::milliseconds(cell.cycleDeadlineMs + 2000);
  std::vector<Shot> out;
  for (int n = 1; n <= shots; ++n) {
    counter = static_cast<std::uint16_t>(counter + 1 == 0 ? 1 : counter + 1);
    if (modbus_write_register(ctx, 2, counter) != 1) return fail(Status::Internal, fmt::format("TRIGGER_ID: {}", modbus_strerror(errno)));
    const auto start = Clock::now();
    bool done = false;
    while (Clock::now() - start < timeout) {
      // RESULT_VALID, not BUSY, and the result is this trigger's (RESULT_ID = ACQ_ID).
      if (read() && (regs[0] & kStatusResultValid) && !(regs[0] & kStatusBusy) && regs[3] == regs[2]) {
        done = true;
        break;
      }
      std::this_thread::sleep_for(std::chrono::milliseconds(2));
    }
    if (!done) {
      failures.push_back({n, "no RESULT_VALID within the cycle deadline"});
      continue;
    }
    const auto code = static_cast<std::int16_t>(regs[1]);
    if (code != 0) {
      failures.push_back({n, fmt::format("status {} {}", code, statusName(static_cast<Status>(code)))});
    } else {
      Shot s;
      for (int k = 0; k < 6; ++k)
        s.v[static_cast<std::size_t>(k)] =
            unpackFloat(regs[8 + 2 * k], regs[9 + 2 * k], cell.modbus.floatWordOrder);  // 24.. = X..R3
      out.push_back(s);
    }
    if (progress && (n % 10 == 0 || n == shots)) {
      std::fprintf(stderr, "\r[%-30s] %d/%d shots", std::string(static_cast<std::size_t>(30 * n / shots), '#').c_str(), n, shots);
      if (n == shots) std::fprintf(stderr, "\n");
    }
    if (intervalMs > 0) std::this_thread::sleep_for(std::chrono::milliseconds(intervalMs));
  }
  return out;
}

using Spread = daemon::AxisSpread;

Spread spread(std::vector<double> v, bool angle) {
  Spread s;
  if (v.empty()) return s;
  if (angle)  // unwrapped around the first shot: 179.9 and -179.9 are 0.2 apart
    for (double& a : v) a = v.front() + std::remainder(a - v.front(), 360.0);
  double sum = 0;
  for (double a : v) sum += a;
  s.mean = sum / static_cast<double>(v.size());
  double ss = 0;
  for (double a : v) ss += (a - s.mean) * (a - s.mean);
  s.sigma = v.size() > 1 ? std::sqrt(ss / static_cast<double>(v.size() - 1)) : 0;  // sample standard deviation
  const auto [lo, hi] = std::minmax_element(v.begin(), v.end());
  s.range = *hi - *lo;
  if (angle) s.mean = normaliseDeg(s.mean);
  return s;
}

// Hands a live run's figures to vgrd for its page (daemon/repeatability_record.hpp): one
// HTTP/1.1 POST with an empty body over a plain socket. Written here rather than with Beast:
// the request is one fixed line and the reply's status line is all we read, and Beast's
// headers would cost the vgr tool a heavy translation unit (STYLE.md).
Result<void> postRecord(const config::WebConfig& web, const daemon::RepeatabilityRun& run) {
  std::string host = web.bind;
  if (host == "0.0.0.0") host = "127.0.0.1";
  if (host == "::") host = "::1";
  addrinfo hints{};
  hints.ai_socktype = SOCK_STREAM;
  hints.ai_flags = AI_NUMERICHOST | AI_NUMERICSERV;
  addrinfo* ai = nullptr;
  if (getaddrinfo(host.c_str(), std::to_string(web.port).c_str(), &hints, &ai) != 0 || !ai)
    return fail(Status::BadArgument, "web.bind " + web.bind + " is not a numeric address");
  const int fd = ::socket(ai->ai_family, SOCK_STREAM | SOCK_CLOEXEC, 0);
  struct Close {
    int fd;
    addrinfo* ai;
    ~Close() {
      if (fd >= 0) ::close(fd);
      freeaddrinfo(ai);
    }
  } guard{fd, ai};
  if (fd < 0) return fail(Status::Internal, "socket() failed");
  timeval tv{5, 0};
  ::setsockopt(fd, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
  ::setsockopt(fd, SOL_SOCKET, SO_SNDTIMEO, &tv, sizeof tv);
  const std::string where = fmt::format("vgrd's web server at {}:{}", host, web.port);
  if (::connect(fd, ai->ai_addr, ai->ai_addrlen) != 0) return fail(Status::CameraError, "cannot reach " + where);
  const std::string req = fmt::format(
      "POST /api/repeatability?{} HTTP/1.1\r\nHost: {}\r\nX-Vgr-Action: 1\r\nContent-Length: 0\r\nConnection: close\r\n\r\n",
      daemon::toQuery(run), host);
  for (std::size_t sent = 0; sent < req.size();) {
    const ssize_t n = ::send(fd, req.data() + sent, req.size() - sent, MSG_NOSIGNAL);
    if (n <= 0) return fail(Status::Internal, "sending to " + where + " failed");
    sent += static_cast<std::size_t>(n);
  }
  std::string reply;
  char buf[4096];
  for (ssize_t n; reply.size() < 65536 && (n = ::recv(fd, buf, sizeof buf, 0)) > 0;) reply.append(buf, static_cast<std::size_t>(n));
  if (reply.rfind("HTTP/1.1 200", 0) == 0) return {};
  const auto body = reply.find("\r\n\r\n");
  const std::string why = reply.empty() ? "no reply" : reply.substr(0, reply.find("\r\n")) +
                                                         (body == std::string::npos ? "" : ": " + reply.substr(body + 4));
  return fail(Status::Internal, where + " did not take it: " + why);
}

}  // namespace

int runRepeatability(const RepeatabilityOptions& o) {
  auto cfg = config::loadCellConfig(o.config);
  if (!cfg) return bad(cfg.error().message);
  const int job = o.job == 0 ? cfg->jobs.front().id : o.job;
  if (!cfg->findJob(job)) return bad(fmt::format("--job {}: no such job in {}", job, o.config));
  if (o.images.empty() && (o.shots < 2 || o.shots > 100000)) return bad("--shots: expected [2, 100000]");

  std::vector<Shot> shots;
  std::vector<Failure> failures;
  std::string source;
  int total = 0;
  if (o.images.empty()) {
    auto live = triggerLive(*cfg, job, o.shots, o.intervalMs, failures, !o.json);
    if (!live) {
      std::fprintf(stderr, "vgr repeatability: %s\n", live.error().message.c_str());
      return live.error().code == Status::BadArgument ? 2 : 1;
    }
    shots = std::move(*live);
    total = o.shots;
    source = fmt::format("live: {} triggers of vgrd at {}:{} (Modbus)", o.shots, cfg->modbus.bind, cfg->modbus.port);
  } else {
    std::vector<std::string> names;
    auto frames = readFrames(o.images, &names);
    if (!frames) return bad(frames.error().message);
    auto mapping = daemon::makeCellMapping(*cfg);
    if (!mapping) return bad("the calibration does not load: " + mapping.error().message);
    auto cj = makeCellJob(*cfg, job);
    if (!cj) return bad(cj.error().message);
    total = static_cast<int>(frames->size());
    for (std::size_t i = 0; i < frames->size(); ++i) {
      auto parts = locateParts(*cj, **mapping, (*frames)[i]);
      if (!parts) {
        failures.push_back({static_cast<int>(i + 1), names[i] + ": " + parts.error().message});
      } else if (parts->empty()) {
        failures.push_back({static_cast<int>(i + 1), names[i] + ": no part found"});
      } else {
        const Pose& p = parts->front().pose;
        const auto e = toEulerZyxDeg(p);
        shots.push_back({{p.x, p.y, p.z, e.rx, e.ry, e.rz}});
      }
    }
    source = fmt::format("replay: {} frame(s)", frames->size());
  }

  std::array<Spread, 6> s;
  for (std::size_t k = 0; k < 6; ++k) {
    std::vector<double> v;
    for (const auto& shot : shots) v.push_back(shot.v[k]);
    s[k] = spread(v, k >= 3);
  }
  const double sigmaMm = std::max({s[0].sigma, s[1].sigma, s[2].sigma});
  const double sigmaDeg = std::max({s[3].sigma, s[4].sigma, s[5].sigma});
  const bool tooFew = shots.size() < 2;
  const bool overBar = (o.maxSigmaMm > 0 && sigmaMm > o.maxSigmaMm) || (o.maxSigmaDeg > 0 && sigmaDeg > o.maxSigmaDeg);
  const bool pass = failures.empty() && !tooFew && !overBar;

  // A live run goes on the cell's page (vgrd keeps it beside its journal).
  std::string recorded;      // where, or why not ("": replay or --no-record)
  bool recordOk = false;
  bool recordFailed = false;  // the cell has a page and vgrd did not take the run
  if (o.images.empty() && o.record) {
    if (!cfg->web.enabled || !cfg->web.page) {
      recorded = "not recorded: the cell has no page (web.enabled / web.page false)";
    } else {
      daemon::RepeatabilityRun run;
      run.job = job;
      run.shots = total;
      run.found = static_cast<int>(shots.size());
      run.failed = static_cast<int>(failures.size());
      for (std::size_t k = 0; k < 6; ++k) run.axes[k] = {s[k].mean, s[k].sigma, s[k].range};
      run.barMm = o.maxSigmaMm;
      run.barDeg = o.maxSigmaDeg;
      run.pass = pass;
      if (auto r = postRecord(cfg->web, run); r) {
        recorded = fmt::format("recorded on the cell's page (http://{}:{}/)", cfg->web.bind, cfg->web.port);
        recordOk = true;
      } else {
        recorded = "NOT recorded on the page: " + r.error().message + " (--no-record measures only)";
        recordFailed = true;
      }
    }
  }

  if (o.json) {
    nlohmann::ordered_json j{{"source", o.images.empty() ? "live" : "replay"}, {"job", job}, {"shots", total},
                             {"found", shots.size()}, {"failed", failures.size()}};
    for (std::size_t k = 0; k < 6; ++k) j[kAxes[k]] = {{"mean", s[k].mean}, {"sigma", s[k].sigma}, {"range", s[k].range}};
    j["max_sigma_mm"] = sigmaMm;
    j["max_sigma_deg"] = sigmaDeg;
    nlohmann::json f = nlohmann::json::array();
    for (const auto& x : failures) f.push_back({{"shot", x.shot}, {"what", x.what}});
    j["failures"] = f;
    j["pass"] = pass;
    if (!recorded.empty()) j["recorded"] = recordOk;
    if (recordFailed) std::fprintf(stderr, "vgr repeatability: %s\n", recorded.c_str());
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("vgr repeatability: job %d, %s; %zu of %d with a part\n", job, source.c_str(), shots.size(), total);
    std::printf("%-8s %12s %10s %10s\n", "axis", "mean", "sigma", "max-min");
    for (std::size_t k = 0; k < 6; ++k)
      std::printf("%-8s %12.4f %10.4f %10.4f\n", kAxes[k], s[k].mean, s[k].sigma, s[k].range);
    for (const auto& x : failures) std::printf("shot %d: %s\n", x.shot, x.what.c_str());
    if (overBar)
      std::printf("FAIL: sigma %.4f mm / %.4f deg above the bar %g mm / %g deg\n", sigmaMm, sigmaDeg, o.maxSigmaMm, o.maxSigmaDeg);
    if (!failures.empty()) std::printf("FAIL: %zu shot(s) delivered no part: a still part must be found every time\n", failures.size());
    if (tooFew && failures.empty()) std::printf("FAIL: fewer than 2 shots\n");
    if (!recorded.empty()) std::printf("%s\n", recorded.c_str());
  }
  return pass && !recordFailed ? 0 : 1;
}

CLI::App* RepeatabilityCommand::add(CLI::App& parent) {
  auto& r = options_;
  auto* c = parent.add_subcommand("repeatability", "N triggers of a still part: spread (sigma, max-min) of x, y, z, rx, ry, rz");
  c->add_option("--config", r.config, "cell config (live: vgrd's Modbus server of it is triggered)")->required();
  c->add_option("--shots", r.shots, "live triggers")->capture_default_str();
  c->add_option("--job", r.job, "job id (default: the cell's first job)")->check(CLI::Range(1, 32767));
  c->add_option("--images", r.images, "replay these frames (files or globs) instead of triggering live");
  c->add_option("--interval-ms", r.intervalMs, "live: pause between shots")->check(CLI::Range(0, 60000));
  c->add_option("--max-sigma-mm", r.maxSigmaMm, "fail (exit 1) when sigma of x, y or z is above this")->check(CLI::PositiveNumber);
  c->add_option("--max-sigma-deg", r.maxSigmaDeg, "fail (exit 1) when sigma of an angle is above this")->check(CLI::PositiveNumber);
  c->add_flag("--json", r.json, "one JSON line");
  c->add_flag("!--no-record", r.record,
              "live: do not hand the figures to vgrd's page (by default they are, when the cell has a page; "
              "failing to is exit 1)");
  return c;
}

}  // namespace vgr::tools
