// Camera intrinsics (Zhang's method, paper 002 "Zhang calibration"; OpenCV calibrateCamera):
// calibration-plate detection with sub-pixel refinement, the solve with per-view errors,
// outlier rejection and re-solve, a coverage/tilt report, and the OpenCV FileStorage YAML
// file (intrinsics.yaml). Pure image/geometry code: no threads, no I/O except read/write.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.hpp"

namespace vgr::vision::calib {

enum class PatternKind { Chessboard, Circles, Charuco };
// "chessboard", "circles" or "charuco"; anything else is an error naming the value.
Result<PatternKind> parsePatternKind(const std::string& name);
const char* patternKindName(PatternKind k);

struct PatternSpec {
  PatternKind kind = PatternKind::Chessboard;
  // chessboard and charuco: inner corners per row / column (squares - 1: a 12 x 9-square
  // board is cols 11, rows 8); circles: circles per row / column (symmetric grid)
  int cols = 9, rows = 6;
  double pitchMm = 20.0;    // square size (chessboard, charuco) or centre spacing (circles), mm
  // charuco only: marker side (mm, < pitchMm) and the ArUco dictionary (OpenCV name).
  double markerMm = 15.0;
  std::string dictionary = "DICT_5X5_100";
};

// Checks cols/rows/pitch and, for charuco, the marker size and that the dictionary exists
// and has a marker for every white square. Errors name the value at fault.
Result<void> validatePatternSpec(const PatternSpec& spec);

// Plate-frame points (mm, z = 0), row-major: point (i, j) = (i * pitch, j * pitch, 0),
// i in [0, cols), j in [0, rows) -- the order the detectors return them in. Charuco: the
// same grid of chessboard corners (i right, j down on the printed board as seen from the
// front; z into the board).
std::vector<cv::Point3f> patternObjectPoints(const PatternSpec& spec);

// The ChArUco board as OpenCV's aruco module lays it out (CharucoBoard::create), in the
// plate frame of patternObjectPoints(). For rendering synthetic plates.
struct CharucoLayout {
  // Marker m (ArUco id m): its four corners in the plate frame (mm) in the order of the
  // marker image: 0 top-left, 1 top-right, 2 bottom-right, 3 bottom-left.
  std::vector<std::array<cv::Point2f, 4>> markers;
  // Marker m's image, one pixel per bit cell including the black border: CV_8UC1, 0 / 255.
  std::vector<cv::Mat> markerImages;
};
Result<CharucoLayout> charucoLayout(const PatternSpec& spec);

struct ViewDetection {
  std::string name;                  // image file name (or a synthetic label)
  bool found = false;
  std::vector<cv::Point2f> corners;  // px, same order as patternObjectPoints() (or as ids)
  // Partial views (charuco): the index into patternObjectPoints() of each corner, ascending.
  // Empty: all points, in patternObjectPoints() order.
  std::vector<int> ids;
  std::string note;  // why the pattern was not used (charuco: too few corners, foreign markers...)
};

// Finds the pattern in an 8-bit gray image; found = false (not an error) when the pattern is
// not there. Chessboard corners are refined with cornerSubPix. Charuco: ArUco markers
// (detectMarkers), then the chessboard corners between them (interpolateCornersCharuco,
// cornerSubPix); the board may be partly outside the image: found = true with at least
// kMinCharucoCorners corners not all on one line, `ids` says which.
constexpr int kMinCharucoCorners = 8;
ViewDetection detectPattern(const cv::Mat& gray, const PatternSpec& spec, const std::string& name);

struct ViewError {
  std::string name;
  double rmsPx = 0;   // reprojection RMS of this view
  double tiltDeg = 0; // angle between the plate normal and the optical axis
  bool used = true;   // false: rejected as an outlier
};

struct CameraIntrinsics {
  cv::Matx33d cameraMatrix = cv::Matx33d::eye();
  cv::Vec<double, 5> dist{0, 0, 0, 0, 0};  // k1, k2, p1, p2, k3 (OpenCV order)
  cv::Size imageSize;
  double rmsPx = 0;                        // RMS reprojection error of the accepted solve
  // Standard deviations of fx, fy, cx, cy (px), k1, k2, p1, p2, k3 estimated from the solve's
  // residuals and Jacobian (0 for a coefficient held fixed, and when read from an old file).
  cv::Vec<double, 9> stdDev = cv::Vec<double, 9>::all(0);
  bool tangential = true;                  // p1, p2 estimated (false: held at 0)
  std::vector<ViewError> views;
  double fx() const { return cameraMatrix(0, 0); }
  double fy() const { return cameraMatrix(1, 1); }
  double cx() const { return cameraMatrix(0, 2); }
  double cy() const { return cameraMatrix(1, 2); }
};

struct CoverageReport {
  double imageCoverage = 0;  // fraction of an 8 x 8 grid of image cells holding a corner
  double minTiltDeg = 0, maxTiltDeg = 0;
  // Significance of the tangential coefficients: |p| / stdDev (0 when not estimated).
  double p1Sigmas = 0, p2Sigmas = 0;
  std::vector<std::string> advice;  // empty: enough views
};

struct IntrinsicsOptions {
  int minViews = 4;            // views with the pattern needed to solve
  double outlierFactor = 3.0;  // a view is an outlier above max(factor * median RMS, outlierFloorPx)
  double outlierFloorPx = 0.5; // px
  // Estimate the tangential distortion p1, p2. Off (CALIB_ZERO_TANGENT_DIST) only for a lens
  // known to have none: a lens that has some then biases the principal point (1-2 px for the
  // synthetic camera's p1 = 6e-4, p2 = -4e-4; docs/calibration.md).
  bool tangential = true;
  // Advice "poorly determined" when 3 standard deviations exceed these.
  double principalPointTolPx = 0.5;
  double focalTolRel = 0.001;
};

struct IntrinsicsResult {
  CameraIntrinsics camera;
  std::vector<cv::Vec3d> rvecs, tvecs;  // T_cam_plate of each used view (same order as used views)
  std::vector<std::string> usedViews;
  std::vector<std::string> rejectedViews;  // outliers removed before the re-solve
  CoverageReport coverage;
};

// Solves from the views with found == true. Errors (Status::BadArgument) name the views at
// fault: too few views with the pattern (listing those without), inconsistent point counts.
Result<IntrinsicsResult> calibrateIntrinsics(const std::vector<ViewDetection>& views, const PatternSpec& spec,
                                             cv::Size imageSize, const IntrinsicsOptions& options = {});

// intrinsics.yaml (OpenCV FileStorage YAML; intrinsics_file.cpp): camera_matrix,
// distortion_coefficients, image_width/height, rms_px, per-view names/errors/used flags.
Result<void> writeIntrinsics(const std::string& path, const CameraIntrinsics& cam);
Result<CameraIntrinsics> readIntrinsics(const std::string& path);

}  // namespace vgr::vision::calib
