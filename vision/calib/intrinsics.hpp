// Camera intrinsics (Zhang's method, paper 002 "Zhang calibration"; OpenCV calibrateCamera):
// calibration-plate detection with sub-pixel refinement, the solve with per-view errors,
// outlier rejection and re-solve, a coverage/tilt report, and the OpenCV FileStorage YAML
// file (intrinsics.yaml). Pure image/geometry code: no threads, no I/O except read/write.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.hpp"

namespace vgr::vision::calib {

enum class PatternKind { Chessboard, Circles };
// "chessboard" or "circles"; anything else is an error naming the value.
Result<PatternKind> parsePatternKind(const std::string& name);
const char* patternKindName(PatternKind k);

struct PatternSpec {
  PatternKind kind = PatternKind::Chessboard;
  int cols = 9, rows = 6;   // chessboard: inner corners per row / column; circles: circles (symmetric grid)
  double pitchMm = 20.0;    // square size (chessboard) or centre spacing (circles), mm
};

// Plate-frame points (mm, z = 0), row-major: point (i, j) = (i * pitch, j * pitch, 0),
// i in [0, cols), j in [0, rows) -- the order the detectors return them in.
std::vector<cv::Point3f> patternObjectPoints(const PatternSpec& spec);

struct ViewDetection {
  std::string name;                  // image file name (or a synthetic label)
  bool found = false;
  std::vector<cv::Point2f> corners;  // px, same order as patternObjectPoints()
};

// Finds the pattern in an 8-bit gray image; chessboard corners are refined with
// cornerSubPix. found = false (not an error) when the pattern is not there.
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
  std::vector<ViewError> views;
  double fx() const { return cameraMatrix(0, 0); }
  double fy() const { return cameraMatrix(1, 1); }
  double cx() const { return cameraMatrix(0, 2); }
  double cy() const { return cameraMatrix(1, 2); }
};

struct CoverageReport {
  double imageCoverage = 0;  // fraction of an 8 x 8 grid of image cells holding a corner
  double minTiltDeg = 0, maxTiltDeg = 0;
  std::vector<std::string> advice;  // empty: enough views
};

struct IntrinsicsOptions {
  int minViews = 4;            // views with the pattern needed to solve
  double outlierFactor = 3.0;  // a view is an outlier above max(factor * median RMS, outlierFloorPx)
  double outlierFloorPx = 0.5; // px
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

// OpenCV FileStorage YAML: camera_matrix, distortion_coefficients, image_width/height, rms_px,
// per-view names/errors/used flags.
Result<void> writeIntrinsics(const std::string& path, const CameraIntrinsics& cam);
Result<CameraIntrinsics> readIntrinsics(const std::string& path);

}  // namespace vgr::vision::calib
