// Hand-eye calibration with a depth camera (paper 003, section 3: "a hand eye calibration
// method based on point cloud registration ... on SE(3)/se(3)"): the calibration target is
// seen as a point cloud in every robot pose (here the centres of the target's spheres,
// sphere_target.hpp), and X is found by registering the clouds of all views onto each
// other through the robot's motion.
//
// Methods, all on the same views (docs/calibration.md has the table):
//   tsai .. rwhe-li    OpenCV's closed forms on B_i = T_cam_target_i, the rigid fit of the
//                      target's centres to each view's points (Kabsch)
//   registration       paper 003 as printed: X alone, every view's cloud registered onto
//                      view 1's through X^-1 A_1^-1 A_i X (eye-in-hand; eq. 2's X^-1 A_1 A_i^-1 X
//                      eye-to-hand), eq. (3) minimised in se(3) (eqs. 4-9) by LM
//   refined-points     X and Y together: every measured point against the target through
//                      A_i, X, Y (robot poses taken as exact), LM in se(3)
//   refined            the same with a correction per robot pose under the robot's stated
//                      repeatability (maximum likelihood; chosen when consistent)
// Frames and X, Y as handeye.hpp; mm and radians; pure functions, any thread.
#pragma once

#include <string>
#include <vector>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/sphere_target.hpp"

namespace vgr::vision::calib {

struct CloudHandEyeView {
  std::string name;          // image file name
  Pose baseFromGripper;      // A_i, as the controller reports it
  std::vector<int> ids;      // target index of each point (matchSphereTarget)
  std::vector<Vec3> points;  // the target's points measured in the camera frame, mm
};

// Solves with every method and picks the best (`refined` when consistent, else the
// consistent method with the lowest point RMS). HandEyeMethodResult::pointRmsMm carries the
// fit in mm (reprojRmsPx stays 0). Errors (Status::BadArgument) as calibrateHandEye: too few
// views, fewer than 4 points in a view, degenerate motion, no consistent method.
Result<HandEyeResult> calibrateHandEyeCloud(const std::vector<CloudHandEyeView>& views, const SphereTarget& target,
                                            HandEyeConfig config, const HandEyeOptions& options = {});
// Both configurations; keeps the one whose best method fits the points better.
Result<HandEyeResult> calibrateHandEyeCloudAuto(const std::vector<CloudHandEyeView>& views, const SphereTarget& target,
                                                const HandEyeOptions& options = {});

}  // namespace vgr::vision::calib
