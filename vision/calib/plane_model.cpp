#include "vision/calib/plane_model.hpp"

#include <cmath>

#include <Eigen/Geometry>

namespace vgr::vision {
namespace {

Eigen::Isometry3d toIso(const Pose& p) {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz).normalized().toRotationMatrix();
  t.translation() = Eigen::Vector3d(p.x, p.y, p.z);
  return t;
}

}  // namespace

PinholePlaneModel::PinholePlaneModel(double fx, double fy, double cx, double cy, const Pose& baseFromCamera,
                                     double planeZ)
    : fx_(fx), fy_(fy), cx_(cx), cy_(cy), baseFromCamera_(baseFromCamera), planeZ_(planeZ) {}

Pose PinholePlaneModel::downLookingCamera(double x, double y, double z, double rzDeg) {
  // R_base_cam = Rz(rz) * Rx(180 deg): camera z points down (-base z).
  const Eigen::Quaterniond q = Eigen::AngleAxisd(rzDeg * M_PI / 180.0, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX());
  return Pose{x, y, z, q.w(), q.x(), q.y(), q.z()};
}

std::optional<Vec3> PinholePlaneModel::pixelToPlane(PixelPoint p, double heightMm) const {
  // Ray through the normalised image point (paper 002, eq. 9), expressed in the base frame
  // (eq. 10), intersected with z = planeZ + h (eq. 11).
  const Eigen::Isometry3d t = toIso(baseFromCamera_);
  const Eigen::Vector3d dirCam((p.u - cx_) / fx_, (p.v - cy_) / fy_, 1.0);
  const Eigen::Vector3d dir = t.linear() * dirCam;
  const Eigen::Vector3d origin = t.translation();
  const double zTarget = planeZ_ + heightMm;
  if (std::abs(dir.z()) < 1e-12) return std::nullopt;
  const double s = (zTarget - origin.z()) / dir.z();
  if (s <= 0) return std::nullopt;
  const Eigen::Vector3d hit = origin + s * dir;
  return Vec3{hit.x(), hit.y(), hit.z()};
}

std::optional<PixelPoint> PinholePlaneModel::project(const Vec3& pb) const {
  const Eigen::Vector3d pc = toIso(baseFromCamera_).inverse() * Eigen::Vector3d(pb.x, pb.y, pb.z);
  if (pc.z() <= 1e-9) return std::nullopt;
  return PixelPoint{cx_ + fx_ * pc.x() / pc.z(), cy_ + fy_ * pc.y() / pc.z()};
}

}  // namespace vgr::vision
