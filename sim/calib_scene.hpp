// Synthetic calibration data with ground truth: calibration plates rendered through a camera
// with known intrinsics and lens distortion, plate poses that keep the pattern in view, and
// robot poses for eye-in-hand and eye-to-hand with known hand-eye transforms and noise.
// Pure functions of their arguments (seeded RNG); no I/O.
#pragma once

#include <cstdint>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/pose.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/intrinsics.hpp"

namespace vgr::config {
struct CellConfig;
}

namespace vgr::sim {

struct TrueCamera {
  cv::Matx33d cameraMatrix;
  cv::Vec<double, 5> dist;  // k1, k2, p1, p2, k3
  cv::Size imageSize;
};

// 800 x 600 px, f = 900 px, principal point off-centre, barrel distortion of a typical
// 8-12 mm industrial lens (k1 = -0.12 -> ~4 px at the image corners).
TrueCamera defaultCalibCamera();

struct PlateRenderOptions {
  double noiseSigma = 1.0;       // gray levels, Gaussian
  std::uint64_t seed = 1;
  int black = 30, white = 220, background = 120;  // gray levels; the plate has a one-pitch white margin
  int supersample = 4;           // samples per pixel per axis (anti-aliasing)
};

// Renders the plate (vision::calib::PatternSpec: chessboard squares or dark circles of
// diameter 0.5 pitch on white) at T_cam_plate through the distorted camera, 8-bit gray.
cv::Mat renderPlate(const TrueCamera& cam, const vision::calib::PatternSpec& spec, const Pose& camFromPlate,
                    const PlateRenderOptions& options);

// The exact image positions of the pattern points (the truth a detector should find).
std::vector<cv::Point2f> projectPattern(const TrueCamera& cam, const vision::calib::PatternSpec& spec,
                                        const Pose& camFromPlate);

// `truth` plus Gaussian noise of sigmaPx on each coordinate.
std::vector<cv::Point2f> addCornerNoise(const std::vector<cv::Point2f>& truth, double sigmaPx, std::uint64_t seed);

// n plate poses T_cam_plate at distanceMm (+-20 %) with tilts up to maxTiltDeg about x and y
// and +-30 deg about z, placed so that every pattern point lies at least marginPx inside the
// image, spread over the image (views near the corners included).
// partialShare (charuco): that share of the views, spread evenly through the set, may show
// the plate partly outside the image (30 % or more of the points inside, at least one
// outside). With a plate larger than the field of view at distanceMm these views fill the
// frame, image corners included, where whole-plate views cannot put many corners; that is
// what pins the principal point down (docs/calibration.md).
std::vector<Pose> randomPlateViews(const TrueCamera& cam, const vision::calib::PatternSpec& spec, int n,
                                   std::uint64_t seed, double distanceMm = 450, double maxTiltDeg = 35,
                                   double marginPx = 25, double partialShare = 0.0);

// The pattern points of a view that project inside the image (marginPx from the border) and
// lie in front of the camera, exact, with their ids (index into patternObjectPoints()), as a
// charuco detector returns them; found when at least kMinCharucoCorners.
vision::calib::ViewDetection visiblePattern(const TrueCamera& cam, const vision::calib::PatternSpec& spec,
                                            const Pose& camFromPlate, double marginPx, const std::string& name);

struct HandEyeScenario {
  vision::calib::HandEyeConfig config;
  Pose x;                         // truth: T_gripper_cam (eye-in-hand) or T_base_cam (eye-to-hand)
  Pose y;                         // truth: T_base_target (eye-in-hand) or T_gripper_target (eye-to-hand)
  std::vector<Pose> robotTrue;    // T_base_gripper as it was
  std::vector<Pose> robotReported;  // with robot noise (what the controller reports)
  std::vector<Pose> camFromPlate; // T_cam_target of each view (truth)
};

// n views whose plate poses come from randomPlateViews(); robot noise is Gaussian per axis
// (mm on x, y, z; degrees as a small rotation vector).
// `fixedX`: the true hand-eye X to use (e.g. a cell's camera mount) instead of the built-in
// one; `distanceMm`: camera-plate distance of the views (randomPlateViews).
HandEyeScenario makeHandEyeScenario(vision::calib::HandEyeConfig config, const TrueCamera& cam,
                                    const vision::calib::PatternSpec& spec, int n, std::uint64_t seed,
                                    double robotNoiseMm, double robotNoiseDeg, const std::optional<Pose>& fixedX = {},
                                    double distanceMm = 450);

// The camera of a cell config's simulated cell (its `model`: the camera the emulator renders
// through, no lens distortion) and its mount T_base_cam.
TrueCamera cellCamera(const config::CellConfig& cell);
Pose cellCameraMount(const config::CellConfig& cell);

}  // namespace vgr::sim
