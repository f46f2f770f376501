#include "vision/calib/se3.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/SVD>
#include <opencv2/calib3d.hpp>

namespace vgr::vision::se3 {
namespace {

Eigen::Matrix3d hat(const Eigen::Vector3d& v) {
  Eigen::Matrix3d m;
  m << 0, -v.z(), v.y(), v.z(), 0, -v.x(), -v.y(), v.x(), 0;
  return m;
}

}  // namespace

Iso toIso(const Pose& p) {
  Iso t = Iso::Identity();
  t.linear() = Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz).normalized().toRotationMatrix();
  t.translation() = Eigen::Vector3d(p.x, p.y, p.z);
  return t;
}

Pose toPose(const Iso& t) {
  Eigen::Quaterniond q(t.linear());
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  const Eigen::Vector3d p = t.translation();
  return Pose{p.x(), p.y(), p.z(), q.w(), q.x(), q.y(), q.z()};
}

Iso fromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec) {
  cv::Matx33d r;
  cv::Rodrigues(rvec, r);
  Iso t = Iso::Identity();
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) t.linear()(i, j) = r(i, j);
  t.translation() = Eigen::Vector3d(tvec[0], tvec[1], tvec[2]);
  return t;
}

void toRvecTvec(const Iso& t, cv::Vec3d& rvec, cv::Vec3d& tvec) {
  cv::Matx33d r;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r(i, j) = t.linear()(i, j);
  cv::Rodrigues(r, rvec);
  tvec = cv::Vec3d(t.translation().x(), t.translation().y(), t.translation().z());
}

Iso expSe3(const Vec6& xi) {
  const Eigen::Vector3d rho = xi.head<3>();
  const Eigen::Vector3d phi = xi.tail<3>();
  const double theta = phi.norm();
  Eigen::Matrix3d r, j;
  if (theta < 1e-10) {
    r = Eigen::Matrix3d::Identity() + hat(phi);
    j = Eigen::Matrix3d::Identity() + 0.5 * hat(phi);
  } else {
    const Eigen::Vector3d a = phi / theta;
    const double s = std::sin(theta), c = std::cos(theta);
    r = c * Eigen::Matrix3d::Identity() + (1 - c) * a * a.transpose() + s * hat(a);
    j = (s / theta) * Eigen::Matrix3d::Identity() + (1 - s / theta) * a * a.transpose() + ((1 - c) / theta) * hat(a);
  }
  Iso t = Iso::Identity();
  t.linear() = r;
  t.translation() = j * rho;
  return t;
}

Vec6 logSe3(const Iso& t) {
  const Eigen::AngleAxisd aa(t.linear());
  const double theta = aa.angle();
  const Eigen::Vector3d phi = aa.axis() * theta;
  Vec6 xi;
  xi.tail<3>() = phi;
  Eigen::Matrix3d j;
  if (theta < 1e-10) {
    j = Eigen::Matrix3d::Identity() + 0.5 * hat(phi);
  } else {
    const Eigen::Vector3d a = aa.axis();
    const double s = std::sin(theta), c = std::cos(theta);
    j = (s / theta) * Eigen::Matrix3d::Identity() + (1 - s / theta) * a * a.transpose() + ((1 - c) / theta) * hat(a);
  }
  xi.head<3>() = j.inverse() * t.translation();
  return xi;
}

double rotationAngleDeg(const Eigen::Matrix3d& r) {
  const double c = std::clamp((r.trace() - 1.0) / 2.0, -1.0, 1.0);
  return std::acos(c) * 180.0 / M_PI;
}

Iso meanIso(const std::vector<Iso>& ts) {
  Eigen::Matrix3d sum = Eigen::Matrix3d::Zero();
  Eigen::Vector3d tsum = Eigen::Vector3d::Zero();
  for (const auto& t : ts) {
    sum += t.linear();
    tsum += t.translation();
  }
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(sum, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixU() * svd.matrixV().transpose()).determinant() < 0 ? -1.0 : 1.0;
  Iso m = Iso::Identity();
  m.linear() = svd.matrixU() * d * svd.matrixV().transpose();
  m.translation() = ts.empty() ? tsum : Eigen::Vector3d(tsum / static_cast<double>(ts.size()));
  return m;
}

bool isValidRigid(const Iso& t) {
  if (!t.matrix().allFinite()) return false;
  const Eigen::Matrix3d r = t.linear();
  if ((r.transpose() * r - Eigen::Matrix3d::Identity()).cwiseAbs().maxCoeff() > 1e-6) return false;
  return std::abs(r.determinant() - 1.0) < 1e-6;
}

}  // namespace vgr::vision::se3
