// `vgr calibrate ...`: intrinsics from plate images, hand-eye from a folder of images + robot
// poses, and synthetic data sets with ground truth (docs/calibration.md). Each returns the
// process exit code: 0 ok, 2 bad input (message on stderr naming file / view / key).
#pragma once

#include <cstdint>
#include <string>

namespace vgr::daemon {

struct CalibPatternOptions {
  std::string pattern = "chessboard";  // chessboard | circles | charuco
  int cols = 9, rows = 6;              // inner corners (chessboard, charuco) / circles per row, column
  double squareMm = 20;                // square size / circle spacing, mm
  double markerMm = 0;                 // charuco marker side, mm (0: 0.75 x square)
  std::string dictionary = "DICT_5X5_100";  // charuco ArUco dictionary
};

struct CalibIntrinsicsOptions {
  std::string images;  // glob, e.g. "/data/calib/*.png"
  CalibPatternOptions pattern;
  std::string out = "intrinsics.yaml";
  bool noTangential = false;  // hold p1 = p2 = 0 (CALIB_ZERO_TANGENT_DIST)
  bool json = false;
};
int runCalibrateIntrinsics(const CalibIntrinsicsOptions& o);

struct CalibHandEyeOptions {
  std::string folder;          // holds poses.txt and the images it names
  std::string intrinsics;      // intrinsics.yaml
  std::string configuration = "auto";  // eye-in-hand | eye-to-hand | auto
  CalibPatternOptions pattern;
  std::string out = "handeye.yaml";
  std::string truth;           // optional: a truth.yaml from `vgr calibrate synth` -> errors per method
  bool json = false;
};
int runCalibrateHandEye(const CalibHandEyeOptions& o);

struct CalibPlaneOptions {
  std::string intrinsics, handeye;  // for --image: intrinsics.yaml and an eye-to-hand handeye.yaml
  std::string image;                // (a) a plate lying on the conveyor
  double thicknessMm = 0;           //     its thickness (the plane is moved down by it)
  std::string points;               // (b) robot-touched points, "x y z" in mm per line
  CalibPatternOptions pattern;
  std::string out = "plane.yaml";
  bool json = false;
};
int runCalibratePlane(const CalibPlaneOptions& o);

struct CalibSynthOptions {
  std::string kind = "intrinsics";     // intrinsics | handeye | cell
  std::string cellConfig;              // cell: the cell config whose camera to use (default: the embedded sim cell)
  std::string out;                     // folder (created)
  std::string configuration = "eye-to-hand";
  std::string poseFormat = "abb";      // abb | fanuc | ur
  CalibPatternOptions pattern;
  int views = 20;
  std::uint64_t seed = 1;
  double robotNoiseMm = 0.05, robotNoiseDeg = 0.01;
  double maxTiltDeg = 40, distanceMm = 420;
  double partialShare = 0;             // share of views with the plate partly outside the image (charuco)
};
int runCalibrateSynth(const CalibSynthOptions& o);

}  // namespace vgr::daemon
