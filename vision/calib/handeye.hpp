// Hand-eye calibration (paper 002: Tsai/Park/Horaud/Daniilidis through OpenCV; paper 003:
// point-cloud registration on SE(3) solved in se(3), eqs. 1-9) for both configurations, with
// every OpenCV method, robot-world-hand-eye, a nonlinear refinement of the reprojection
// error over SE(3), consistency residuals per method and checks for degenerate pose sets.
//
// Frames (T_a_b maps points from b to a; mm, radians):
//   A_i = T_base_gripper_i   robot pose i as the controller reports it
//   B_i = T_cam_target_i     plate pose from solvePnP in view i
//   eye-in-hand (camera on the flange, plate fixed):   X = T_gripper_cam, Y = T_base_target,
//                                                      A_i X B_i = Y
//   eye-to-hand (camera fixed, plate on the flange):   X = T_base_cam,    Y = T_gripper_target,
//                                                      X B_i = A_i Y
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/calib/intrinsics.hpp"

namespace vgr::vision::calib {

enum class HandEyeConfig { EyeInHand, EyeToHand };
const char* handEyeConfigName(HandEyeConfig c);  // "eye-in-hand", "eye-to-hand"

struct HandEyeView {
  std::string name;                  // image file name
  Pose baseFromGripper;              // A_i, mm + quaternion
  std::vector<cv::Point2f> corners;  // detected pattern points, patternObjectPoints() order
};

struct HandEyeMethodResult {
  std::string method;          // "tsai", "park", ..., "refined-reproj", "refined", "registration"
  bool valid = false;          // false: threw, NaN, not a rotation, or inconsistent (see note)
  std::string note;            // why it was rejected, or empty
  Pose x, y;                   // X and Y as defined above (Y fitted to X when the method gives only X)
  double transResidMm = 0;     // RMS over views of |Y_i - Y| translation (Y_i from view i)
  double rotResidDeg = 0;      // RMS over views of the angle of Y_i Y^-1
  double reprojRmsPx = 0;      // RMS reprojection error of the plate through A_i, X, Y
  double pointRmsMm = 0;       // depth camera (handeye_cloud.hpp): RMS distance of the measured
                               // target points to the target through A_i, X, Y; 0 otherwise
};

struct HandEyeResult {
  HandEyeConfig config = HandEyeConfig::EyeInHand;
  std::vector<HandEyeMethodResult> methods;
  int best = -1;                       // index into methods
  std::string reason;                  // why `best` was chosen
  std::vector<std::string> warnings;   // duplicates, little rotation, ...
  const HandEyeMethodResult& bestResult() const { return methods.at(static_cast<std::size_t>(best)); }
};

struct HandEyeOptions {
  int minViews = 3;
  double minRotationDeg = 10;      // below this largest relative rotation: degenerate (error)
  double minAxisSpreadDeg = 5;     // relative-rotation axes all within this of each other: degenerate
  double duplicateMm = 0.5, duplicateDeg = 0.1;  // two poses closer than both: duplicate (warning)
  double maxRotResidDeg = 2.0;     // a method whose consistency residual exceeds these is rejected
  double maxTransResidMm = 20.0;
  // Noise model of the joint refinement ("refined"): the robot's pose repeatability and the
  // corner noise (0: estimated from the reprojection-only fit).
  double robotSigmaMm = 0.05, robotSigmaDeg = 0.01;
  double cornerSigmaPx = 0;
};

// Solves for X and Y with every method and picks the best. Errors (Status::BadArgument) name
// the views at fault: too few views, corner count mismatch, degenerate motion.
Result<HandEyeResult> calibrateHandEye(const std::vector<HandEyeView>& views, const CameraIntrinsics& cam,
                                       const PatternSpec& pattern, HandEyeConfig config,
                                       const HandEyeOptions& options = {});

// Runs both configurations and keeps the one whose best method is most consistent (the
// other one's methods tend to throw or return NaN: OpenCV 4.6 pitfalls). Returns the
// chosen result; the other configuration's error/summary goes into its warnings.
Result<HandEyeResult> calibrateHandEyeAuto(const std::vector<HandEyeView>& views, const CameraIntrinsics& cam,
                                           const PatternSpec& pattern, const HandEyeOptions& options = {});

// handeye.yaml (OpenCV FileStorage; handeye_file.cpp): configuration, X and Y as 4x4
// matrices (mm), the chosen method, its residuals and every method's residuals.
Result<void> writeHandEye(const std::string& path, const HandEyeResult& r);
// A synthetic set's truth in the same layout (`vgr calibrate handeye --truth` reads it).
Result<void> writeHandEyeTruth(const std::string& path, HandEyeConfig config, const Pose& x, const Pose& y);
struct HandEyeFile {
  HandEyeConfig config = HandEyeConfig::EyeInHand;
  Pose x, y;
  std::string method;
  double transResidMm = 0, rotResidDeg = 0, reprojRmsPx = 0;
  double pointRmsMm = 0;  // depth-camera calibrations (key point_rms_mm; 0 when absent)
};
Result<HandEyeFile> readHandEye(const std::string& path);

// The robot pose file the views' baseFromGripper come from: vision/calib/robot_pose_file.hpp.
// With a depth camera the target is measured as points in mm, not pixels:
// vision/calib/handeye_cloud.hpp (paper 003's point-cloud registration).

}  // namespace vgr::vision::calib
