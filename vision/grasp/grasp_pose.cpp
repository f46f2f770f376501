#include "vision/grasp/grasp_pose.hpp"

#include <cmath>

#include <Eigen/Geometry>
#include <fmt/core.h>

namespace vgr::vision::grasp {
namespace {

constexpr double kDeg = M_PI / 180.0;

// The two jaw points in the image: centre +- half the opening along the closing axis
// (counter-clockwise as displayed, so image y runs against the angle's sine).
void jawPixels(const Grasp& g, double& u0, double& v0, double& u1, double& v1) {
  const double c = std::cos(g.angleDeg * kDeg), s = std::sin(g.angleDeg * kDeg), h = g.widthPx / 2;
  u0 = g.u - c * h, v0 = g.v + s * h;
  u1 = g.u + c * h, v1 = g.v - s * h;
}

Result<RobotGrasp> fromPoints(const Eigen::Vector3d& centre, const Eigen::Vector3d& j0, const Eigen::Vector3d& j1) {
  const Eigen::Vector3d axis = j1 - j0;
  if (std::hypot(axis.x(), axis.y()) < 1e-6 * (axis.norm() + 1e-12))
    return fail(Status::NotCalibrated, "grasp: the closing axis maps along base z (the camera does not look down on the work plane)");
  double ang = std::atan2(axis.y(), axis.x()) / kDeg;
  while (ang <= -90) ang += 180;
  while (ang > 90) ang -= 180;
  RobotGrasp r;
  r.centre = Vec3{centre.x(), centre.y(), centre.z()};
  r.angleDeg = ang;
  r.widthMm = axis.norm();
  r.pose = poseFromXyzRz(centre.x(), centre.y(), centre.z(), ang * kDeg);
  return r;
}

}  // namespace

Result<RobotGrasp> graspToRobot3d(const Grasp& g, const DepthIntrinsics& cam, const Pose& baseFromCamera) {
  if (!(g.depthMm > 0) || !(cam.fx > 0) || !(cam.fy > 0))
    return fail(Status::BadArgument, fmt::format("grasp at ({:.1f}, {:.1f}) px has no depth", g.u, g.v));
  const Eigen::Quaterniond q(baseFromCamera.qw, baseFromCamera.qx, baseFromCamera.qy, baseFromCamera.qz);
  const Eigen::Vector3d t(baseFromCamera.x, baseFromCamera.y, baseFromCamera.z);
  auto toBase = [&](double u, double v) {
    const auto p = backProject(cam, u, v, g.depthMm);
    return Eigen::Vector3d(q.normalized() * Eigen::Vector3d(p.x, p.y, p.z) + t);
  };
  double u0, v0, u1, v1;
  jawPixels(g, u0, v0, u1, v1);
  return fromPoints(toBase(g.u, g.v), toBase(u0, v0), toBase(u1, v1));
}

Result<RobotGrasp> graspToRobotPlane(const Grasp& g, const calib::PixelMapping& mapping) {
  double u0, v0, u1, v1;
  jawPixels(g, u0, v0, u1, v1);
  const auto c = mapping.pixelToRobot({g.u, g.v}, g.heightMm);
  const auto a = mapping.pixelToRobot({u0, v0}, g.heightMm);
  const auto b = mapping.pixelToRobot({u1, v1}, g.heightMm);
  if (!c || !a || !b)
    return fail(Status::NotCalibrated, fmt::format("grasp at ({:.1f}, {:.1f}) px, {:.1f} mm high: {} cannot map it", g.u, g.v, g.heightMm,
                                                   mapping.describe()));
  return fromPoints({c->x, c->y, c->z}, {a->x, a->y, a->z}, {b->x, b->y, b->z});
}

}  // namespace vgr::vision::grasp
