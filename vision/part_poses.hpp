// Detections (image pixels) -> part poses in the robot base frame: the one place the cycle
// (vgrd) and `vgr locate` turn what a locator found into what a robot gets.
//
// For each detection: the grasp point and a point 20 px along the part's axis (the
// detection's angle, CCW as displayed) are both mapped onto the work plane at the part's
// grasp height (paper 002 eqs. (9)-(11): the "virtual plane" raised by the part height);
// the direction between them is the part's rotation about base z, plus the job's
// angle offset (template axis vs. the part's frame). The offset is T_ref^-1 * T_part from
// the job's taught reference. Score and label are carried over. A detection whose pixels
// cannot be mapped (ray misses the plane, outside a multi-height grid) yields no part.
// Pure; any thread.
#pragma once

#include <vector>

#include "core/cycle.hpp"  // PartResult
#include "core/pose.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/locate/locator.hpp"  // Detection

namespace vgr::vision {

struct PartPoseRules {
  double heightMm = 0;        // mm: grasp height above the work plane
  double angleOffsetDeg = 0;  // deg: added to the mapped rotation
  Pose reference;             // base frame: the taught reference the offsets are given from
};

std::vector<PartResult> partPoses(const std::vector<Detection>& found, const calib::PixelMapping& mapping,
                                  const PartPoseRules& rules);

}  // namespace vgr::vision
