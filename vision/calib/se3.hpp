// SE(3) helpers for calibration: conversions between vgr::Pose, Eigen isometries and OpenCV
// rvec/tvec, the se(3) exponential (paper 003, eqs. 4-8) and rotation averaging.
// Units: mm and radians. T_a_b maps points from frame b to frame a.
#pragma once

#include <vector>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>

#include "core/pose.hpp"

namespace vgr::vision::se3 {

using Iso = Eigen::Isometry3d;
using Vec6 = Eigen::Matrix<double, 6, 1>;

Iso toIso(const Pose& p);
Pose toPose(const Iso& t);
Iso fromRvecTvec(const cv::Vec3d& rvec, const cv::Vec3d& tvec);
void toRvecTvec(const Iso& t, cv::Vec3d& rvec, cv::Vec3d& tvec);

// exp: se(3) -> SE(3). xi = (rho, phi): rho translation part (mm), phi rotation vector (rad).
// Paper 003 eq. (6)-(8) with the full Rodrigues formula (its eq. (7) as printed drops the
// sin(theta) a^ term) and the left Jacobian J for the translation.
Iso expSe3(const Vec6& xi);
// log: SE(3) -> se(3), the inverse of expSe3 (rotation angle in [0, pi]).
Vec6 logSe3(const Iso& t);

double rotationAngleDeg(const Eigen::Matrix3d& r);  // angle of r in degrees, [0, 180]

// Chordal L2 mean of rotations (SVD projection of the summed matrices) and mean translation.
Iso meanIso(const std::vector<Iso>& ts);

// True when every entry is finite and the linear part is a proper rotation (|R^T R - I| and
// |det R - 1| below 1e-6).
bool isValidRigid(const Iso& t);

}  // namespace vgr::vision::se3
