// Limits a job puts on the parts it delivers (cell.yaml `jobs[].limits`, docs/protocols.md
// "Limits"): on the offset from the job's taught reference and on the absolute pose (the
// work area). A part outside them is not delivered: the cycle answers -9
// OFFSET_OUT_OF_LIMITS when no part within them is left.
//   offset    : T_ref^-1 * T_part (PartResult::offset): x, y, z in mm along the reference's
//               own axes (the taught part's frame), rx, ry, rz its Z-Y-X Euler angles in
//               degrees (R = Rz(rz) Ry(ry) Rx(rx), each in (-180, 180]).
//   work area : the part's pose in the robot base frame, x, y, z mm and Z-Y-X degrees.
// An axis without an interval is not limited. Pure; any thread.
#pragma once

#include <optional>
#include <string>

#include "core/pose.hpp"

namespace vgr {

struct Interval {
  double lo = 0, hi = 0;  // lo <= hi; mm or degrees (angles within [-180, 180])
};

struct PoseLimits {
  std::optional<Interval> x, y, z;     // mm
  std::optional<Interval> rx, ry, rz;  // deg, Z-Y-X
  bool empty() const { return !x && !y && !z && !rx && !ry && !rz; }
};

struct JobLimits {
  PoseLimits offset;    // from the taught reference
  PoseLimits workArea;  // absolute, base frame
  bool empty() const { return offset.empty() && workArea.empty(); }
};

// "" when `pose` (base frame) and `offset` (T_ref^-1 * T_part) are within `limits`; else
// the first violation, e.g. "offset x 62.100 mm outside [-50, 50]" or
// "work area rz -170.000 deg outside [-90, 90]".
std::string limitViolation(const JobLimits& limits, const Pose& pose, const Pose& offset);

}  // namespace vgr
