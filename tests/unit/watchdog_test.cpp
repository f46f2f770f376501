// vgrd's watchdog decision (daemon/watchdog.hpp): a thread is stalled only when its last
// beat is older than its own limit; a thread that never beat has not started.
#include <gtest/gtest.h>

#include <chrono>
#include <thread>

#include "core/heartbeat.hpp"
#include "daemon/watchdog.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::Heartbeat;
using vgr::daemon::Watchdog;

TEST(Watchdog, FreshBeatsAreNotStalled) {
  Heartbeat cycle, camera;
  Watchdog w;
  w.watch("cycle", cycle, 100ms);
  w.watch("camera", camera, 1000ms);
  cycle.beat();
  camera.beat();
  EXPECT_TRUE(w.stalled(Watchdog::Clock::now()).empty());
}

TEST(Watchdog, EachThreadHasItsOwnLimitAndTheWorstComesFirst) {
  Heartbeat cycle, camera, modbus;
  Watchdog w;
  w.watch("cycle", cycle, 100ms);
  w.watch("camera", camera, 1000ms);
  w.watch("modbus", modbus, 200ms);
  cycle.beat();
  camera.beat();
  modbus.beat();
  const auto later = Watchdog::Clock::now() + 500ms;
  const auto s = w.stalled(later);
  ASSERT_EQ(s.size(), 2u);          // camera (1000 ms limit) is not stalled after 500 ms
  EXPECT_EQ(s[0].thread, "cycle");  // beat first, so silent a little longer than modbus
  EXPECT_EQ(s[1].thread, "modbus");
  EXPECT_GE(s[0].silentFor, 500ms);
  EXPECT_EQ(s[0].limit, 100ms);
  EXPECT_EQ(s[1].limit, 200ms);
}

TEST(Watchdog, TheLongestSilentThreadIsReportedFirst) {
  Heartbeat a, b;
  Watchdog w;
  w.watch("a", a, 10ms);
  w.watch("b", b, 10ms);
  a.beat();
  std::this_thread::sleep_for(30ms);
  b.beat();
  const auto s = w.stalled(Watchdog::Clock::now() + 50ms);
  ASSERT_EQ(s.size(), 2u);
  EXPECT_EQ(s[0].thread, "a");
  EXPECT_GT(s[0].silentFor, s[1].silentFor);
}

TEST(Watchdog, AThreadThatNeverBeatIsNotStalled) {
  Heartbeat never;
  Watchdog w;
  w.watch("never", never, 1ms);
  EXPECT_TRUE(w.stalled(Watchdog::Clock::now() + 10s).empty());
  never.beat();
  EXPECT_EQ(w.stalled(Watchdog::Clock::now() + 10s).size(), 1u);
}

TEST(Watchdog, ABeatEndsTheStall) {
  Heartbeat h;
  Watchdog w;
  w.watch("cycle", h, 20ms);
  h.beat();
  std::this_thread::sleep_for(40ms);
  EXPECT_EQ(w.stalled(Watchdog::Clock::now()).size(), 1u);
  h.beat();
  EXPECT_TRUE(w.stalled(Watchdog::Clock::now()).empty());
}

}  // namespace
