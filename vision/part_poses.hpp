// Detections (image pixels) -> part poses in the robot base frame: the one place the cycle
// (vgrd) and `vgr locate` turn what a locator found into what a robot gets.
//
// For each detection: the grasp point and a point 20 px along the part's axis (the
// detection's angle, CCW as displayed) are both mapped onto the work plane at the part's
// grasp height (paper 002 eqs. (9)-(11): the "virtual plane" raised by the part height);
// the direction between them is the part's rotation about base z, plus the job's
// angle offset (template axis vs. the part's frame). The offset is T_ref^-1 * T_part from
// the job's taught reference. Score, label and scale are carried over. A detection whose
// pixels cannot be mapped (ray misses the plane, outside a multi-height grid) yields no part.
//
// Scale (a job with a scale range, Detection::scale = image px per template px): the template
// was taught with the grasp point at `heightMm`; a part seen s times as large lies on the
// same ray at 1/s of the distance from the camera, i.e. it is nearer the camera when seen
// larger, and is mapped on the plane through that point: Hc - h = (Hc - heightMm) / s, Hc
// the camera's height above the work plane along the plane normal. Hc comes from the
// mapping itself (every PixelMapping, the multi-height map too, has no other way to say
// it): on parallel planes the mm per px at a pixel is proportional to Hc - h, so two
// heights give it (scaleHeightMm). pose.z then says how high the part is. The angle needs
// no correction: turning about the plane normal looks the same at any height.
// Pure; any thread.
#pragma once

#include <optional>
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

// The height (mm above the work plane) at which a part seen at `scale` at pixel p lies, for
// a template taught at heightMm (see above). Empty when the mapping cannot say (a pixel
// it cannot map, planes that do not shrink toward a camera).
std::optional<double> scaleHeightMm(const calib::PixelMapping& mapping, PixelPoint p, double heightMm, double scale);

std::vector<PartResult> partPoses(const std::vector<Detection>& found, const calib::PixelMapping& mapping,
                                  const PartPoseRules& rules);

}  // namespace vgr::vision
