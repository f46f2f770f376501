// Debouncer of the Modbus client mode (protocol/modbus_client_trigger.hpp): the laser
// sensor input must hold a new level for the debounce time before it counts.
#include "protocol/modbus_client_trigger.hpp"

#include <gtest/gtest.h>

namespace vgr::protocol {
namespace {

using namespace std::chrono_literals;
using Clock = Debouncer::Clock;

TEST(modbus_debounce, LevelCountsAfterHoldTime) {
  Debouncer d(20ms);
  const auto t = Clock::now();
  EXPECT_FALSE(d.sample(true, t).has_value());
  EXPECT_FALSE(d.sample(true, t + 19ms).has_value());
  const auto edge = d.sample(true, t + 20ms);
  ASSERT_TRUE(edge.has_value());
  EXPECT_TRUE(*edge);
  EXPECT_TRUE(d.level());
  EXPECT_FALSE(d.sample(true, t + 40ms).has_value());  // one edge only
  EXPECT_FALSE(d.sample(false, t + 41ms).has_value());
  ASSERT_TRUE(d.sample(false, t + 61ms).has_value());
  EXPECT_FALSE(d.level());
}

TEST(modbus_debounce, ChatterRestartsTheHoldTime) {
  Debouncer d(20ms);
  const auto t = Clock::now();
  d.sample(true, t);
  d.sample(false, t + 5ms);  // bounce
  d.sample(true, t + 10ms);  // the hold restarts here
  EXPECT_FALSE(d.sample(true, t + 25ms).has_value());
  EXPECT_TRUE(d.sample(true, t + 30ms).has_value());
  // A short dropout while high never produces a falling edge.
  EXPECT_FALSE(d.sample(false, t + 40ms).has_value());
  EXPECT_FALSE(d.sample(true, t + 45ms).has_value());
  EXPECT_FALSE(d.sample(false, t + 50ms).has_value());
  EXPECT_FALSE(d.sample(false, t + 69ms).has_value());
  EXPECT_TRUE(d.sample(false, t + 70ms).has_value());
}

TEST(modbus_debounce, ZeroHoldPassesEverySample) {
  Debouncer d(0ms);
  const auto t = Clock::now();
  EXPECT_EQ(d.sample(true, t), std::optional<bool>(true));
  EXPECT_EQ(d.sample(false, t), std::optional<bool>(false));
}

}  // namespace
}  // namespace vgr::protocol
