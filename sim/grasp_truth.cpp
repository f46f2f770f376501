#include "sim/grasp_truth.hpp"

#include <cmath>

#include <Eigen/Geometry>
#include <fmt/core.h>

namespace vgr::sim {
namespace {

using V3 = Eigen::Vector3d;

constexpr double kDeg = M_PI / 180.0;

CanonicalGrasp grasp(std::string name, V3 a, V3 b, V3 closing, double section) {
  return {std::move(name), {a.x(), a.y(), a.z()}, {b.x(), b.y(), b.z()}, {closing.x(), closing.y(), closing.z()}, section};
}

// The image point of a camera-frame point (mm); z > 0 is checked by the callers.
Eigen::Vector2d project(const DepthCameraModel& c, const V3& p) {
  return {c.fx * p.x() / p.z() + c.cx, c.fy * p.y() / p.z() + c.cy};
}

bool insideImage(const DepthCameraModel& c, const Eigen::Vector2d& q) {
  return q.x() >= 0 && q.y() >= 0 && q.x() <= c.width - 1 && q.y() <= c.height - 1;
}

double exactZAt(const cv::Mat& z, const Eigen::Vector2d& q) {
  return z.at<double>(static_cast<int>(std::lround(q.y())), static_cast<int>(std::lround(q.x())));
}

// Lines of centres across a face: segment a -> b moved along `step` (a unit model axis) by
// every kGraspStepMm from lo to hi mm, each line its own canonical grasp `name@AXIS+N`.
// A parallel gripper's jaws (kJawLengthMm long) fit anywhere on a face, not on one line:
// the true centres must cover the face, or the rectangle metric, which accepts a match
// with any true rectangle, calls as good a grasp beside the one line a miss.
void faceLines(std::vector<CanonicalGrasp>& out, const std::string& name, const V3& a, const V3& b, const V3& step, char axis, int lo,
               int hi, const V3& closing, double section) {
  for (int o = lo; o <= hi; o += static_cast<int>(kGraspStepMm))
    out.push_back(grasp(fmt::format("{}@{}{:+d}", name, axis, o), a + step * o, b + step * o, closing, section));
}

}  // namespace

// The part geometry is sim/depth_parts.cpp's (mm, model frame). Sections, each a face of
// centres (faceLines(): lines every 2 mm wherever the 10 mm jaws fit on the faces they
// close on):
//   bracket  flange: across its 8 mm thickness (y -20..-12), z 13..35 (above the base
//            plate's top 8 + 5, below its top edge 40 - 5);
//            base-width: across the whole part (y -20..20, 40 mm) at the base plate's
//            mid-height (z 4: above it the section is the flange's);
//            base-thickness: across the 8 mm base plate (z 0..8), y -7..15 (from the
//            flange's face -12 + 5 to the free long edge 20 - 5), for a bracket on its side
//   housing  block-width: across the 36 mm block (y), z 5..17 (its height 0..22, less 5);
//            block-height: across its 22 mm height (z), y -12..12 (the 36 mm side faces,
//            less 5), for a housing on its side or on an end
//   lever    arm: across the 10 mm arm (y) at mid-height, between the hubs
// Round features (bosses, hubs) are left out: a grasp on them has no defined angle.
// Where a rib, boss, lug or hub stands in a jaw's way, sceneGraspTruth's rule (3) removes
// those centres.
Result<std::vector<CanonicalGrasp>> canonicalGrasps(const std::string& part) {
  if (auto p = depthPart(part); !p) return std::unexpected(p.error());
  const V3 y = V3::UnitY(), z = V3::UnitZ();
  std::vector<CanonicalGrasp> g;
  if (part == "bracket") {
    faceLines(g, "flange", {-25, -16, 0}, {25, -16, 0}, z, 'z', 13, 35, y, 8);
    g.push_back(grasp("base-width", {-25, 0, 4}, {25, 0, 4}, y, 40));
    faceLines(g, "base-thickness", {-25, 0, 4}, {25, 0, 4}, y, 'y', -7, 15, z, 8);
  } else if (part == "housing") {
    faceLines(g, "block-width", {-20, 0, 0}, {20, 0, 0}, z, 'z', 5, 17, y, 36);
    faceLines(g, "block-height", {-20, 0, 11}, {20, 0, 11}, y, 'y', -12, 12, z, 22);
  } else {
    g.push_back(grasp("arm", {14, 0, 4}, {48, 0, 4}, y, 10));
  }
  return g;
}

Result<std::vector<GraspTruth>> sceneGraspTruth(const DepthScene& scene, const std::string& part) {
  auto grasps = canonicalGrasps(part);
  if (!grasps) return std::unexpected(grasps.error());
  const DepthCameraModel& cam = scene.camera;
  if (scene.exactZ.type() != CV_64FC1 || scene.exactZ.rows != cam.height || scene.exactZ.cols != cam.width ||
      scene.labels.type() != CV_16UC1 || scene.labels.size() != scene.exactZ.size())
    return fail(Status::BadArgument, "grasp truth: the scene has no exact z or label image of the camera's size");

  std::vector<GraspTruth> out;
  for (std::size_t k = 0; k < scene.parts.size(); ++k) {
    const Pose& p = scene.parts[k].pose;
    const Eigen::Quaterniond q(p.qw, p.qx, p.qy, p.qz);
    const V3 t(p.x, p.y, p.z);
    for (const auto& g : *grasps) {
      const V3 a = q * V3(g.a[0], g.a[1], g.a[2]) + t, b = q * V3(g.b[0], g.b[1], g.b[2]) + t;
      const V3 closing = q * V3(g.closing[0], g.closing[1], g.closing[2]);
      // (1) closing axis within kGraspMaxTiltDeg of the image plane
      if (std::abs(closing.z()) > std::sin(kGraspMaxTiltDeg * kDeg)) continue;
      // The jaws move in the plane perpendicular to the optical axis: across = the closing
      // axis in that plane, along = perpendicular to it.
      const V3 across = V3(closing.x(), closing.y(), 0).normalized();
      const V3 along = V3::UnitZ().cross(across);
      const double opening = g.sectionMm + 2 * kJawClearanceMm;
      const int samples = static_cast<int>(std::floor((b - a).norm() / kGraspStepMm + 1e-9)) + 1;
      for (int s = 0; s < samples; ++s) {
        const V3 c = a + (b - a).normalized() * (s * kGraspStepMm);
        if (c.z() < 1) continue;
        const Eigen::Vector2d pc = project(cam, c);
        // (4) the rectangle inside the image
        bool inside = true;
        for (int i = -1; i <= 1; i += 2)
          for (int j = -1; j <= 1; j += 2)
            inside = inside && insideImage(cam, project(cam, c + across * (i * opening / 2) + along * (j * kJawLengthMm / 2)));
        if (!inside) continue;
        // (2) the part is the nearest surface at the centre, at most kGraspMaxReachMm above it
        const int ui = static_cast<int>(std::lround(pc.x())), vi = static_cast<int>(std::lround(pc.y()));
        if (scene.labels.at<std::uint16_t>(vi, ui) != k + 1) continue;
        const double reach = c.z() - scene.exactZ.at<double>(vi, ui);
        if (reach < 0 || reach > kGraspMaxReachMm) continue;
        // (3) both jaw footprints, sampled every 0.5 mm at the centre's depth: nothing nearer
        // to the camera than the centre
        bool free = true;
        for (int side = -1; side <= 1 && free; side += 2) {
          const V3 jaw = c + across * (side * (g.sectionMm / 2 + kJawClearanceMm + kJawThickMm / 2));
          for (double da = -kJawThickMm / 2; da <= kJawThickMm / 2 + 1e-9 && free; da += 0.5)
            for (double db = -kJawLengthMm / 2; db <= kJawLengthMm / 2 + 1e-9 && free; db += 0.5) {
              const Eigen::Vector2d f = project(cam, jaw + across * da + along * db);
              free = insideImage(cam, f) && exactZAt(scene.exactZ, f) > c.z();
            }
        }
        if (!free) continue;

        GraspTruth gt;
        gt.part = static_cast<int>(k);
        gt.grasp = g.name;
        gt.sample = s;
        gt.u = pc.x(), gt.v = pc.y();
        const Eigen::Vector2d j0 = project(cam, c - across * (opening / 2)), j1 = project(cam, c + across * (opening / 2));
        double ang = std::atan2(-(j1.y() - j0.y()), j1.x() - j0.x()) / kDeg;
        if (ang <= -90) ang += 180;
        if (ang > 90) ang -= 180;
        gt.angleDeg = ang;
        gt.widthPx = (j1 - j0).norm();
        gt.jawPx = (project(cam, c + along * (kJawLengthMm / 2)) - project(cam, c - along * (kJawLengthMm / 2))).norm();
        gt.centreCam = Vec3{c.x(), c.y(), c.z()};
        gt.widthMm = opening;
        out.push_back(std::move(gt));
      }
    }
  }
  return out;
}

}  // namespace vgr::sim
