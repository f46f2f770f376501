// The parts of hand-eye calibration that do not care how the target was measured, shared by
// the camera-image solver (handeye.cpp: plate corners in pixels) and the depth-camera solver
// (handeye_cloud.cpp: target points in mm): the pose-set checks, every OpenCV closed form
// (checked), the consistency of Y over the views, and the joint maximum-likelihood
// refinement over X, Y and a correction per robot pose.
//
// Frames as in handeye.hpp: A_i = T_base_gripper_i, B_i = T_cam_target_i;
//   eye-in-hand X = T_gripper_cam, Y = T_base_target, A_i X B_i = Y;
//   eye-to-hand X = T_base_cam,    Y = T_gripper_target, X B_i = A_i Y.
// mm and radians. Pure functions; any thread.
#pragma once

#include <functional>
#include <optional>
#include <string>
#include <vector>

#include <Eigen/Core>

#include "core/result.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/se3.hpp"

namespace vgr::vision::calib::handeye_detail {

using se3::Iso;

// Y seen through one view for a given X.
Iso yFromView(HandEyeConfig config, const Iso& a, const Iso& x, const Iso& b);
// T_cam_target predicted by the chain A, X, Y.
Iso camFromTarget(HandEyeConfig config, const Iso& a, const Iso& x, const Iso& y);

// How well the views agree on Y for this X: RMS over views of |Y_i - Y| and of the angle of
// Y_i Y^-1, with Y the given one or (null) the mean of the Y_i.
struct Consistency {
  double transMm = 0, rotDeg = 0;
  Iso y = Iso::Identity();
};
Consistency consistency(HandEyeConfig config, const std::vector<Iso>& a, const std::vector<Iso>& b, const Iso& x,
                        const Iso* y);

// Fewer than options.minViews, too little rotation, one rotation axis: errors naming the
// views; duplicates and very large rotations: warnings.
Result<void> checkPoseSet(const std::vector<std::string>& names, const std::vector<Iso>& a,
                          const HandEyeOptions& options, std::vector<std::string>& warnings);

// Every OpenCV closed form (Tsai, Park, Horaud, Andreff, Daniilidis; robot-world-hand-eye
// Shah and Li), each caught and checked: `x` empty with `note` saying why (OpenCV threw, NaN,
// not a rigid transform or beyond 100 m).
struct ClosedForm {
  std::string method;  // "tsai", ..., "rwhe-li"
  std::optional<Iso> x;
  std::string note;
};
std::vector<ClosedForm> closedFormSolutions(HandEyeConfig config, const std::vector<Iso>& a, const std::vector<Iso>& b);

// Joint maximum-likelihood refinement of X, Y and a small correction C_i per robot pose
// (C_i = exp(xi_i), paper 003 eqs. 4-8 for the parametrisation, updated in se(3)): A_i' has
// A_i's flange turned by C_i's rotation about the flange's own origin and shifted by C_i's
// translation -- the robot's repeatability as position and orientation error at the flange.
// viewResiduals(x, y, A_i', i, out) writes view i's `residualsPerView` measurement residuals,
// already divided by their sigma; the prior (translation / sigmaMm, rotation vector /
// sigmaRad) of C_i is appended per view.
// Hand-written LM (levmarq.hpp's damping) using the block structure: C_i only moves view i.
// `corrected` (optional) receives the corrected robot poses A_i' of the solution.
using ViewResidualFn =
    std::function<void(const Iso& x, const Iso& y, const Iso& aCorrected, std::size_t view, Eigen::Ref<Eigen::VectorXd> out)>;
void refineJoint(const std::vector<Iso>& a, std::size_t residualsPerView, const ViewResidualFn& viewResiduals, Iso& x,
                 Iso& y, double sigmaMm, double sigmaRad, std::vector<Iso>* corrected = nullptr);

}  // namespace vgr::vision::calib::handeye_detail
