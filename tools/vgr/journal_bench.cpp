#include "tools/vgr/journal_bench.hpp"

#include <time.h>
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>
#include <nlohmann/json.hpp>

#include "core/pose.hpp"
#include "daemon/journal.hpp"

namespace vgr::tools {

namespace {

double threadCpuUs() {
  timespec ts{};
  ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
  return static_cast<double>(ts.tv_sec) * 1e6 + static_cast<double>(ts.tv_nsec) / 1e3;
}

double at(std::vector<double> v, double q) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[static_cast<std::size_t>(std::lround(q * static_cast<double>(v.size() - 1)))];
}

double r1(double v) { return std::round(v * 10.0) / 10.0; }

}  // namespace

int runJournalBench(const JournalBenchOptions& o) {
  namespace fs = std::filesystem;
  std::error_code ec;
  const fs::path dir = fs::path(o.dir) / ("vgr-journal-bench-" + std::to_string(::getpid()));
  fs::create_directories(dir, ec);
  if (ec) return badInput("vgr journal-bench: cannot create " + dir.string() + ": " + ec.message());
  // A typical record: one part, every field filled (~450 bytes of JSON).
  CycleResult r;
  r.jobId = 1;
  r.status = Status::Ok;
  r.frameId = 4711;
  r.grabMs = 21.9;
  r.locateMs = 3.4;
  r.totalMs = 25.5;
  r.triggerTime = std::chrono::system_clock::now();
  PartResult p;
  p.pose = poseFromXyzRz(412.345, -87.654, 0.0, 0.7);
  p.offset = poseFromXyzRz(12.345, -87.654, 0.0, 0.7);
  p.uPx = 818.264;
  p.vPx = 270.409;
  p.angleImgDeg = -133.966;
  p.score = 0.987;
  r.parts.push_back(p);

  const struct {
    const char* name;
    int syncMs;
  } policies[] = {{"every_record", 0}, {"every_1000_ms", 1000}, {"never", -1}};
  for (const auto& policy : policies) {
    const fs::path path = dir / (std::string(policy.name) + ".jsonl");
    daemon::Journal journal;
    daemon::JournalOptions jo;
    jo.syncMs = policy.syncMs;
    if (auto opened = journal.open(path.string(), jo); !opened) return badInput("vgr journal-bench: " + opened.error().message);
    std::vector<double> wall, cpu;
    wall.reserve(static_cast<std::size_t>(o.records));
    cpu.reserve(static_cast<std::size_t>(o.records));
    for (int i = 0; i < o.records; ++i) {
      r.cycleId = static_cast<std::uint32_t>(i + 1);
      const auto w0 = std::chrono::steady_clock::now();
      const double c0 = threadCpuUs();
      journal.append(r);
      cpu.push_back(threadCpuUs() - c0);
      wall.push_back(std::chrono::duration<double, std::micro>(std::chrono::steady_clock::now() - w0).count());
      if (o.periodMs > 0) std::this_thread::sleep_for(std::chrono::milliseconds(o.periodMs));
    }
    const daemon::JournalStats st = journal.stats();
    double sum = 0;
    for (double v : wall) sum += v;
    nlohmann::ordered_json j = {{"policy", policy.name},
                                {"records", o.records},
                                {"period_ms", o.periodMs},
                                {"wall_us_mean", r1(sum / static_cast<double>(wall.size()))},
                                {"wall_us_p50", r1(at(wall, 0.5))},
                                {"wall_us_p99", r1(at(wall, 0.99))},
                                {"wall_us_max", r1(at(wall, 1.0))},
                                {"cpu_us_p50", r1(at(cpu, 0.5))},
                                {"cpu_us_p99", r1(at(cpu, 0.99))},
                                {"syncs", st.syncs},
                                {"sync_us_mean", st.syncs ? r1(static_cast<double>(st.syncMicros) / static_cast<double>(st.syncs)) : 0.0},
                                {"dir", o.dir}};
    std::printf("%s\n", j.dump().c_str());
    std::fflush(stdout);
  }
  fs::remove_all(dir, ec);
  return 0;
}

CLI::App* JournalBenchCommand::add(CLI::App& parent) {
  auto& o = options_;
  auto* cmd = parent.add_subcommand("journal-bench", "the journal's cost per record under each fsync policy (docs/journal.md)");
  cmd->add_option("--records", o.records, "appends per policy")->check(CLI::Range(10, 10000000))->capture_default_str();
  cmd->add_option("--period-ms", o.periodMs, "pause between appends, ms")->check(CLI::Range(0, 10000))->capture_default_str();
  cmd->add_option("--dir", o.dir, "folder on the disk to measure")->capture_default_str();
  return cmd;
}

}  // namespace vgr::tools
