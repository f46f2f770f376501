// daemon/pause_probe: the figures that tell why vgrd did not run (docs/robustness.md "Pauses").
#include <gtest/gtest.h>

#include <time.h>

#include <chrono>
#include <cstdint>

#include "daemon/pause_probe.hpp"

namespace vgr::daemon {
namespace {

using namespace std::chrono_literals;

TEST(pause_probe, ParsesTheKernelsFiles) {
  const auto s = parseSchedstat("123456789 987654 42\n");
  ASSERT_TRUE(s);
  EXPECT_EQ(s->first, 123456789);
  EXPECT_EQ(s->second, 987654);
  EXPECT_FALSE(parseSchedstat("12 x 3\n"));
  EXPECT_FALSE(parseSchedstat(""));

  EXPECT_EQ(parseStealTicks("cpu  3682708 2585742 1450769 1767181 14966 0 41016 8462 0 0\ncpu0 1 2 3 4 5 6 7 8 9 10\n"), 8462);
  EXPECT_FALSE(parseStealTicks("cpu0 1 2 3 4 5 6 7 8\n"));  // not the summary line
  EXPECT_FALSE(parseStealTicks("cpu 1 2 3\n"));              // too old a kernel

  const char* psi = "some avg10=88.76 avg60=47.23 avg300=50.36 total=27075332378\n"
                    "full avg10=1.50 avg60=0.00 avg300=0.00 total=0\n";
  EXPECT_DOUBLE_EQ(*parsePressureAvg10(psi, "some"), 88.76);
  EXPECT_DOUBLE_EQ(*parsePressureAvg10(psi, "full"), 1.50);
  EXPECT_FALSE(parsePressureAvg10("some avg10=x avg60=0\n", "some"));
  EXPECT_FALSE(parsePressureAvg10(psi, "none"));
}

PauseSample at(std::int64_t runMs, std::int64_t waitMs, std::int64_t stealTicks) {
  PauseSample s;
  s.runNs = runMs * 1'000'000;
  s.waitNs = waitMs * 1'000'000;
  s.stealTicks = stealTicks;
  s.cpuSome = 12.5;
  return s;
}

TEST(pause_probe, TheVerdictFollowsTheFigures) {
  const std::vector<std::pair<std::string, std::chrono::milliseconds>> silent = {{"cycle", 2400ms}, {"camera", 2390ms}};
  const std::string starved = PauseProbe::describe(2450ms, at(100, 10, 0), at(101, 2300, 0), silent);
  EXPECT_NE(starved.find("fired 2450 ms late"), std::string::npos) << starved;
  EXPECT_NE(starved.find("waited 2290 ms for a CPU and ran 1 ms"), std::string::npos) << starved;
  EXPECT_NE(starved.find("cycle 2400 ms, camera 2390 ms"), std::string::npos) << starved;
  EXPECT_NE(starved.find("cpu some 12.5 %"), std::string::npos) << starved;
  EXPECT_NE(starved.find("given no CPU"), std::string::npos) << starved;

  const std::string blocked = PauseProbe::describe(2450ms, at(100, 10, 0), at(101, 40, 0), silent);
  EXPECT_NE(blocked.find("not runnable"), std::string::npos) << blocked;

  const std::string busy = PauseProbe::describe(900ms, at(100, 10, 0), at(1000, 10, 0), silent);
  EXPECT_NE(busy.find("itself was busy"), std::string::npos) << busy;

  PauseSample none;  // a kernel without the files
  const std::string unknown = PauseProbe::describe(900ms, none, none, {});
  EXPECT_NE(unknown.find("waited n/a"), std::string::npos) << unknown;
  EXPECT_NE(unknown.find("unknown"), std::string::npos) << unknown;
}

TEST(pause_probe, ReportsOnlyLateTicks) {
  PauseProbe p;
  const auto t0 = PauseProbe::Clock::now();
  EXPECT_FALSE(p.tick(t0, t0 + 2s, {}));  // the first tick only samples
  EXPECT_FALSE(p.tick(t0, t0 + 499ms, {}));
  const auto line = p.tick(t0, t0 + 1200ms, {{"cycle", 1200ms}});
  ASSERT_TRUE(line);
  EXPECT_NE(line->find("fired 1200 ms late"), std::string::npos) << *line;
  EXPECT_EQ(p.pauses(), 1u);
  EXPECT_EQ(p.worst(), 1200ms);
}

// The real kernel's figures for this thread: 60 ms of this thread's CPU time (its own clock,
// so the machine's load does not matter) show as >= 50 ms on a CPU in schedstat.
TEST(pause_probe, ReadsThisThreadsSchedulerFigures) {
  const PauseSample before = PauseProbe::sample();
  if (!before.runNs) GTEST_SKIP() << "no /proc/thread-self/schedstat on this kernel";
  const auto cpuNs = [] {
    timespec ts{};
    ::clock_gettime(CLOCK_THREAD_CPUTIME_ID, &ts);
    return static_cast<std::int64_t>(ts.tv_sec) * 1'000'000'000 + ts.tv_nsec;
  };
  const std::int64_t start = cpuNs();
  volatile std::uint64_t x = 0;
  while (cpuNs() - start < 60'000'000) x = x + 1;
  const PauseSample after = PauseProbe::sample();
  ASSERT_TRUE(after.runNs);
  EXPECT_GE(*after.runNs - *before.runNs, 50'000'000) << "ran " << (*after.runNs - *before.runNs) << " ns";
  EXPECT_GE(*after.waitNs, *before.waitNs);
}

}  // namespace
}  // namespace vgr::daemon
