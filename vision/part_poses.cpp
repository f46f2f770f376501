#include "vision/part_poses.hpp"

#include <cmath>
#include <numbers>

namespace vgr::vision {

std::vector<PartResult> partPoses(const std::vector<Detection>& found, const calib::PixelMapping& mapping,
                                  const PartPoseRules& rules) {
  constexpr double kDegToRad = std::numbers::pi / 180.0;
  constexpr double kAxisStepPx = 20;  // long enough to average pixel noise, short enough to stay on the part
  std::vector<PartResult> parts;
  parts.reserve(found.size());
  const Pose toReference = inverse(rules.reference);
  for (const Detection& d : found) {
    const double a = d.angleDeg * kDegToRad;
    const auto p = mapping.pixelToRobot({d.u, d.v}, rules.heightMm);
    const auto q = mapping.pixelToRobot({d.u + kAxisStepPx * std::cos(a), d.v - kAxisStepPx * std::sin(a)}, rules.heightMm);
    if (!p || !q) continue;
    const double rz = std::atan2(q->y - p->y, q->x - p->x) + rules.angleOffsetDeg * kDegToRad;
    PartResult part;
    part.pose = poseFromXyzRz(p->x, p->y, p->z, std::remainder(rz, 2 * std::numbers::pi));
    part.offset = compose(toReference, part.pose);
    part.uPx = d.u;
    part.vPx = d.v;
    part.angleImgDeg = d.angleDeg;
    part.score = d.score;
    part.label = d.label;
    part.confidence = d.confidence;
    parts.push_back(part);
  }
  return parts;
}

}  // namespace vgr::vision
