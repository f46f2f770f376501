#include "vision/part_poses.hpp"

#include <cmath>
#include <numbers>

namespace vgr::vision {

std::optional<double> scaleHeightMm(const calib::PixelMapping& mapping, PixelPoint p, double heightMm, double scale) {
  if (scale == 1) return heightMm;
  if (!(scale > 0)) return std::nullopt;
  // mm per px at p on the plane at height h: the square root of the area a 20 x 20 px square maps to.
  constexpr double kHalf = 10;
  auto mmPerPx = [&](double h) -> std::optional<double> {
    const auto a = mapping.pixelToRobot({p.u - kHalf, p.v}, h), b = mapping.pixelToRobot({p.u + kHalf, p.v}, h);
    const auto c = mapping.pixelToRobot({p.u, p.v - kHalf}, h), d = mapping.pixelToRobot({p.u, p.v + kHalf}, h);
    if (!a || !b || !c || !d) return std::nullopt;
    const Vec3 e1{b->x - a->x, b->y - a->y, b->z - a->z}, e2{d->x - c->x, d->y - c->y, d->z - c->z};
    const Vec3 n{e1.y * e2.z - e1.z * e2.y, e1.z * e2.x - e1.x * e2.z, e1.x * e2.y - e1.y * e2.x};
    return std::sqrt(std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z)) / (2 * kHalf);
  };
  // A second height 10 mm off (below if above fails: a multi-height grid has a top and a bottom).
  std::optional<double> m0 = mmPerPx(heightMm), m1;
  double h1 = heightMm + 10;
  if (m0) m1 = mmPerPx(h1);
  if (m0 && !m1) h1 = heightMm - 10, m1 = mmPerPx(h1);
  if (!m0 || !m1) return std::nullopt;
  // m(h) = k (Hc - h): k = (m0 - m1) / (h1 - h0); Hc - h0 = m0 / k.
  const double k = (*m0 - *m1) / (h1 - heightMm);
  if (!(k > 1e-9)) return std::nullopt;
  const double distance = *m0 / k;  // Hc - heightMm, mm
  return heightMm + distance * (1 - 1 / scale);
}

std::vector<PartResult> partPoses(const std::vector<Detection>& found, const calib::PixelMapping& mapping,
                                  const PartPoseRules& rules) {
  constexpr double kDegToRad = std::numbers::pi / 180.0;
  constexpr double kAxisStepPx = 20;  // long enough to average pixel noise, short enough to stay on the part
  std::vector<PartResult> parts;
  parts.reserve(found.size());
  const Pose toReference = inverse(rules.reference);
  for (const Detection& d : found) {
    const double a = d.angleDeg * kDegToRad;
    const auto h = scaleHeightMm(mapping, {d.u, d.v}, rules.heightMm, d.scale);
    if (!h) continue;
    const auto p = mapping.pixelToRobot({d.u, d.v}, *h);
    const auto q = mapping.pixelToRobot({d.u + kAxisStepPx * std::cos(a), d.v - kAxisStepPx * std::sin(a)}, *h);
    if (!p || !q) continue;
    const double rz = std::atan2(q->y - p->y, q->x - p->x) + rules.angleOffsetDeg * kDegToRad;
    PartResult part;
    part.pose = poseFromXyzRz(p->x, p->y, p->z, std::remainder(rz, 2 * std::numbers::pi));
    part.offset = compose(toReference, part.pose);
    part.uPx = d.u;
    part.vPx = d.v;
    part.angleImgDeg = d.angleDeg;
    part.scale = d.scale;
    part.score = d.score;
    part.label = d.label;
    part.confidence = d.confidence;
    parts.push_back(part);
  }
  return parts;
}

}  // namespace vgr::vision
