#include "core/pose_limits.hpp"

#include <fmt/format.h>

namespace vgr {
namespace {

std::string check(const PoseLimits& l, const char* what, const Pose& p) {
  if (l.empty()) return {};
  const EulerZyxDeg e = toEulerZyxDeg(p);
  struct Axis {
    const char* name;
    const std::optional<Interval>& range;
    double value;
    const char* unit;
  };
  const Axis axes[] = {{"x", l.x, p.x, "mm"},    {"y", l.y, p.y, "mm"},    {"z", l.z, p.z, "mm"},
                       {"rx", l.rx, e.rx, "deg"}, {"ry", l.ry, e.ry, "deg"}, {"rz", l.rz, e.rz, "deg"}};
  for (const Axis& a : axes) {
    if (!a.range) continue;
    // A NaN is outside every interval (the comparisons below are false for it).
    if (!(a.value >= a.range->lo && a.value <= a.range->hi))
      return fmt::format("{} {} {:.3f} {} outside [{:g}, {:g}]", what, a.name, a.value, a.unit, a.range->lo, a.range->hi);
  }
  return {};
}

}  // namespace

std::string limitViolation(const JobLimits& limits, const Pose& pose, const Pose& offset) {
  if (std::string why = check(limits.offset, "offset", offset); !why.empty()) return why;
  return check(limits.workArea, "work area", pose);
}

}  // namespace vgr
