#include "core/pose.hpp"

#include <cmath>

#include <Eigen/Geometry>

namespace vgr {
namespace {

Eigen::Quaterniond quat(const Pose& p) { return Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz).normalized(); }

Pose fromEigen(const Eigen::Vector3d& t, const Eigen::Quaterniond& q) {
  Eigen::Quaterniond n = q.normalized();
  if (n.w() < 0) n.coeffs() *= -1.0;  // canonical hemisphere: w >= 0
  return Pose{t.x(), t.y(), t.z(), n.w(), n.x(), n.y(), n.z()};
}

constexpr double kRadToDeg = 180.0 / M_PI;

}  // namespace

Pose poseFromXyzRz(double x, double y, double z, double rzRad) {
  return fromEigen({x, y, z}, Eigen::Quaterniond(Eigen::AngleAxisd(rzRad, Eigen::Vector3d::UnitZ())));
}

EulerZyxDeg toEulerZyxDeg(const Pose& p) {
  // R = Rz(a) Ry(b) Rx(c); b = asin(-r20). Near the singularity (|b| = 90 deg) rx is set
  // to 0 and rz absorbs the remaining rotation, so the three angles still rebuild R.
  const Eigen::Matrix3d r = quat(p).toRotationMatrix();
  const double sy = -r(2, 0);
  double rz, ry, rx;
  if (std::abs(sy) < 1.0 - 1e-12) {
    ry = std::asin(sy);
    rz = std::atan2(r(1, 0), r(0, 0));
    rx = std::atan2(r(2, 1), r(2, 2));
  } else {
    ry = sy > 0 ? M_PI / 2 : -M_PI / 2;
    rx = 0.0;
    rz = std::atan2(-r(0, 1), r(1, 1));
  }
  return {rz * kRadToDeg, ry * kRadToDeg, rx * kRadToDeg};
}

Vec3 toRotationVector(const Pose& p) {
  const Eigen::AngleAxisd aa(quat(p));
  double angle = aa.angle();
  Eigen::Vector3d axis = aa.axis();
  if (angle > M_PI) {  // keep the angle in [0, pi]
    angle = 2 * M_PI - angle;
    axis = -axis;
  }
  const Eigen::Vector3d v = axis * angle;
  return {v.x(), v.y(), v.z()};
}

Pose poseFromEulerZyxDeg(double x, double y, double z, const EulerZyxDeg& e) {
  constexpr double kDegToRad = M_PI / 180.0;
  const Eigen::Quaterniond q = Eigen::AngleAxisd(e.rz * kDegToRad, Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(e.ry * kDegToRad, Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(e.rx * kDegToRad, Eigen::Vector3d::UnitX());
  return fromEigen({x, y, z}, q);
}

Pose poseFromRotationVector(double x, double y, double z, const Vec3& rv) {
  const Eigen::Vector3d v(rv.x, rv.y, rv.z);
  const double angle = v.norm();
  const Eigen::Quaterniond q =
      angle < 1e-15 ? Eigen::Quaterniond::Identity() : Eigen::Quaterniond(Eigen::AngleAxisd(angle, v / angle));
  return fromEigen({x, y, z}, q);
}

Pose poseFromQuaternion(double x, double y, double z, double qw, double qx, double qy, double qz) {
  return fromEigen({x, y, z}, Eigen::Quaterniond(qw, qx, qy, qz));
}

Pose compose(const Pose& a, const Pose& b) {
  const Eigen::Quaterniond qa = quat(a);
  const Eigen::Vector3d t = Eigen::Vector3d(a.x, a.y, a.z) + qa * Eigen::Vector3d(b.x, b.y, b.z);
  return fromEigen(t, qa * quat(b));
}

Pose inverse(const Pose& p) {
  const Eigen::Quaterniond qi = quat(p).conjugate();
  return fromEigen(-(qi * Eigen::Vector3d(p.x, p.y, p.z)), qi);
}

}  // namespace vgr
