// Evidence for a pause of vgrd (docs/robustness.md "Pauses"): when the I/O thread's periodic
// watchdog timer fires much later than it was due, vgrd did not run for that long, and the
// soak of issue 19 saw one such 2.45 s pause of every thread at once without being able to
// say why. This samples, at every watchdog tick, what tells the causes apart:
//   - the I/O thread's own scheduler figures (/proc/thread-self/schedstat: ns on a CPU, ns
//     runnable but waiting for one): waiting ~ the pause -> the machine gave vgrd no CPU;
//     neither -> the thread was not runnable (blocked on a lock or I/O, or the process was
//     stopped);
//   - the machine's steal time (/proc/stat, cpu line): the hypervisor took the CPU away;
//   - pressure stall information (/proc/pressure/{cpu,io,memory}, "some"/"full" avg10 %);
//   - how long each watched thread had been silent (passed in by the caller).
// Reading three small /proc files once per tick (<= 1/s) on the I/O thread; nothing on the
// cycle's hot path. A file that cannot be read (older kernel, no PSI) is reported as "n/a".
// I/O thread only.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>
#include <utility>
#include <vector>

namespace vgr::daemon {

// "run_ns wait_ns timeslices" (/proc/<pid>/task/<tid>/schedstat): {run_ns, wait_ns}.
std::optional<std::pair<std::int64_t, std::int64_t>> parseSchedstat(std::string_view text);
// The "steal" column (8th value) of /proc/stat's first "cpu" line, in USER_HZ ticks.
std::optional<std::int64_t> parseStealTicks(std::string_view procStat);
// avg10 of the "some" or "full" line of a /proc/pressure file, in %.
std::optional<double> parsePressureAvg10(std::string_view text, std::string_view line);

struct PauseSample {
  std::optional<std::int64_t> runNs, waitNs;  // this thread
  std::optional<std::int64_t> stealTicks;     // the machine
  std::optional<double> cpuSome, ioSome, ioFull, memSome, memFull;  // PSI avg10, %
};

class PauseProbe {
 public:
  using Clock = std::chrono::steady_clock;
  // A tick this late is a pause worth a log line: far above the timer slack of a loaded
  // machine (tens of ms), below the robots' reply deadlines (1.5 s in the sim cell).
  static constexpr std::chrono::milliseconds kReportLate{500};

  // Reads the /proc files (the calling thread's schedstat).
  static PauseSample sample();

  // Called at every tick with when it was due and the watched threads' silences. Returns the
  // log line when the tick came >= kReportLate late (comparing with the previous tick's
  // sample), nullopt otherwise. The first call only takes the sample.
  std::optional<std::string> tick(Clock::time_point due, Clock::time_point now,
                                  const std::vector<std::pair<std::string, std::chrono::milliseconds>>& silences);

  // The line for a pause of `late` between samples `before` and `after` (pure; tests).
  static std::string describe(std::chrono::milliseconds late, const PauseSample& before, const PauseSample& after,
                              const std::vector<std::pair<std::string, std::chrono::milliseconds>>& silences);

  std::uint64_t pauses() const { return pauses_; }
  std::chrono::milliseconds worst() const { return worst_; }

 private:
  std::optional<PauseSample> last_;
  std::uint64_t pauses_ = 0;
  std::chrono::milliseconds worst_{0};
};

}  // namespace vgr::daemon
