#include "daemon/pause_probe.hpp"

#include <unistd.h>

#include <charconv>
#include <fstream>
#include <iterator>
#include <sstream>

namespace vgr::daemon {

namespace {

std::optional<std::string> slurp(const char* path) {
  std::ifstream in(path);
  if (!in) return std::nullopt;
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  return text;
}

// The whitespace-separated fields of `line`.
std::vector<std::string_view> fields(std::string_view line) {
  std::vector<std::string_view> out;
  std::size_t i = 0;
  while (i < line.size()) {
    while (i < line.size() && (line[i] == ' ' || line[i] == '\t')) ++i;
    const std::size_t start = i;
    while (i < line.size() && line[i] != ' ' && line[i] != '\t') ++i;
    if (i > start) out.push_back(line.substr(start, i - start));
  }
  return out;
}

std::optional<std::int64_t> toInt(std::string_view s) {
  std::int64_t v = 0;
  const auto [p, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc() || p != s.data() + s.size() || v < 0) return std::nullopt;
  return v;
}

std::string_view firstLine(std::string_view text) { return text.substr(0, text.find('\n')); }

std::string ms(std::optional<std::int64_t> a, std::optional<std::int64_t> b, double perUnitMs) {
  if (!a || !b || *b < *a) return "n/a";
  return std::to_string(static_cast<std::int64_t>(static_cast<double>(*b - *a) * perUnitMs + 0.5)) + " ms";
}

std::string pct(std::optional<double> v) {
  if (!v) return "n/a";
  std::ostringstream o;
  o.precision(3);
  o << *v << " %";
  return o.str();
}

}  // namespace

std::optional<std::pair<std::int64_t, std::int64_t>> parseSchedstat(std::string_view text) {
  const auto f = fields(firstLine(text));
  if (f.size() < 2) return std::nullopt;
  const auto run = toInt(f[0]);
  const auto wait = toInt(f[1]);
  if (!run || !wait) return std::nullopt;
  return std::make_pair(*run, *wait);
}

std::optional<std::int64_t> parseStealTicks(std::string_view procStat) {
  const auto f = fields(firstLine(procStat));
  // cpu user nice system idle iowait irq softirq steal ...
  if (f.size() < 9 || f[0] != "cpu") return std::nullopt;
  return toInt(f[8]);
}

std::optional<double> parsePressureAvg10(std::string_view text, std::string_view line) {
  while (!text.empty()) {
    const std::string_view l = firstLine(text);
    const auto f = fields(l);
    if (f.size() >= 2 && f[0] == line && f[1].substr(0, 6) == "avg10=") {
      const std::string v(f[1].substr(6));
      char* end = nullptr;
      const double d = std::strtod(v.c_str(), &end);
      if (end == v.c_str() || *end != '\0' || d < 0) return std::nullopt;
      return d;
    }
    if (l.size() == text.size()) break;
    text.remove_prefix(l.size() + 1);
  }
  return std::nullopt;
}

PauseSample PauseProbe::sample() {
  PauseSample s;
  if (const auto t = slurp("/proc/thread-self/schedstat"))
    if (const auto p = parseSchedstat(*t)) {
      s.runNs = p->first;
      s.waitNs = p->second;
    }
  if (const auto t = slurp("/proc/stat")) s.stealTicks = parseStealTicks(*t);
  if (const auto t = slurp("/proc/pressure/cpu")) s.cpuSome = parsePressureAvg10(*t, "some");
  if (const auto t = slurp("/proc/pressure/io")) {
    s.ioSome = parsePressureAvg10(*t, "some");
    s.ioFull = parsePressureAvg10(*t, "full");
  }
  if (const auto t = slurp("/proc/pressure/memory")) {
    s.memSome = parsePressureAvg10(*t, "some");
    s.memFull = parsePressureAvg10(*t, "full");
  }
  return s;
}

std::string PauseProbe::describe(std::chrono::milliseconds late, const PauseSample& before, const PauseSample& after,
                                 const std::vector<std::pair<std::string, std::chrono::milliseconds>>& silences) {
  const long hz = ::sysconf(_SC_CLK_TCK);
  const double msPerTick = hz > 0 ? 1000.0 / static_cast<double>(hz) : 10.0;
  std::ostringstream o;
  o << "pause: the I/O thread's watchdog timer fired " << late.count() << " ms late (vgrd did not run for that long); "
    << "meanwhile the I/O thread waited " << ms(before.waitNs, after.waitNs, 1e-6) << " for a CPU and ran "
    << ms(before.runNs, after.runNs, 1e-6) << ", the machine's steal time grew "
    << ms(before.stealTicks, after.stealTicks, msPerTick) << "; pressure avg10 now: cpu some " << pct(after.cpuSome)
    << ", io some " << pct(after.ioSome) << " full " << pct(after.ioFull) << ", memory some " << pct(after.memSome)
    << " full " << pct(after.memFull) << "; threads silent:";
  for (const auto& [name, silent] : silences) o << ' ' << name << ' ' << silent.count() << " ms,";
  if (silences.empty()) o << " none watched,";
  // The verdict: which of the causes the figures point at.
  const double half = static_cast<double>(late.count()) / 2.0;
  const bool waited = before.waitNs && after.waitNs && static_cast<double>(*after.waitNs - *before.waitNs) * 1e-6 >= half;
  const bool stolen = before.stealTicks && after.stealTicks &&
                      static_cast<double>(*after.stealTicks - *before.stealTicks) * msPerTick >= half;
  const bool busy = before.runNs && after.runNs && static_cast<double>(*after.runNs - *before.runNs) * 1e-6 >= half;
  o << " so: ";
  if (busy)
    o << "the I/O thread itself was busy (a long handler on it)";
  else if (waited)
    o << "runnable but given no CPU (the machine was overloaded)";
  else if (stolen)
    o << "the hypervisor took the CPU away (steal time)";
  else if (before.waitNs && after.waitNs)
    o << "not runnable: blocked (a lock, disk I/O, page faults) or the process was stopped";
  else
    o << "unknown (no scheduler figures)";
  return o.str();
}

std::optional<std::string> PauseProbe::tick(Clock::time_point due, Clock::time_point now,
                                            const std::vector<std::pair<std::string, std::chrono::milliseconds>>& silences) {
  PauseSample s = sample();
  std::optional<std::string> line;
  const auto late = std::chrono::duration_cast<std::chrono::milliseconds>(now - due);
  if (last_ && late >= kReportLate) {
    ++pauses_;
    if (late > worst_) worst_ = late;
    line = describe(late, *last_, s, silences);
  }
  last_ = std::move(s);
  return line;
}

}  // namespace vgr::daemon
