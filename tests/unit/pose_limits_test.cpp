// Job limits (core/pose_limits.hpp): offset from the reference and absolute work area; the
// first violation is named with its value and interval; NaN is never within.
#include <gtest/gtest.h>

#include <cmath>

#include "core/pose_limits.hpp"

namespace vgr {
namespace {

TEST(pose_limits, EmptyLimitsAcceptEverything) {
  EXPECT_TRUE(JobLimits{}.empty());
  EXPECT_EQ(limitViolation(JobLimits{}, poseFromEulerZyxDeg(1e5, -1e5, 3, EulerZyxDeg{170, 80, -170}), Pose{}), "");
}

TEST(pose_limits, EachAxisIsChecked) {
  JobLimits l;
  l.offset.x = Interval{-50, 50};
  l.offset.rz = Interval{-30, 30};
  l.workArea.y = Interval{-100, 100};
  l.workArea.ry = Interval{-1, 1};
  const Pose ok = poseFromEulerZyxDeg(400, 20, 0, EulerZyxDeg{10, 0, 0});
  EXPECT_EQ(limitViolation(l, ok, poseFromEulerZyxDeg(49.9, 0, 0, EulerZyxDeg{29.9, 0, 0})), "");
  EXPECT_EQ(limitViolation(l, ok, poseFromEulerZyxDeg(62.1, 0, 0, EulerZyxDeg{0, 0, 0})), "offset x 62.100 mm outside [-50, 50]");
  EXPECT_EQ(limitViolation(l, ok, poseFromEulerZyxDeg(0, 0, 0, EulerZyxDeg{-45, 0, 0})), "offset rz -45.000 deg outside [-30, 30]");
  EXPECT_EQ(limitViolation(l, poseFromEulerZyxDeg(400, 120, 0, EulerZyxDeg{0, 0, 0}), Pose{}), "work area y 120.000 mm outside [-100, 100]");
  EXPECT_EQ(limitViolation(l, poseFromEulerZyxDeg(400, 0, 0, EulerZyxDeg{0, 2.5, 0}), Pose{}), "work area ry 2.500 deg outside [-1, 1]");
  // Both bounds are inside.
  EXPECT_EQ(limitViolation(l, ok, poseFromEulerZyxDeg(-50, 0, 0, EulerZyxDeg{30, 0, 0})), "");
}

TEST(pose_limits, NanIsOutside) {
  JobLimits l;
  l.workArea.x = Interval{0, 1000};
  Pose p;
  p.x = std::nan("");
  EXPECT_NE(limitViolation(l, p, Pose{}), "");
}

}  // namespace
}  // namespace vgr
