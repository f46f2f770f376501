// multiheight.yaml (OpenCV FileStorage): the samples of paper 001's multi-height
// calibration (section 4.1) — the robot-touched grid at height 0, the plane normal, the
// heights and where each grid point was seen at each height — with the image size and the
// k-segment fit residuals it was accepted with. The map is rebuilt from the samples on
// load (MultiHeightMap::build is cheap), so the file holds measurements, not derived data.
// Reading and writing live here together. Errors carry Status::NotCalibrated and name the
// file and the key.
#pragma once

#include <string>
#include <vector>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/calib/multi_height.hpp"
#include "vision/calib/pixel_mapping.hpp"  // ImageSize

namespace vgr::vision::calib {

struct MultiHeightSamples {
  int rows = 0, cols = 0;                          // grid points per column / row, >= 2 each
  std::vector<Vec3> gridBase;                      // rows * cols points at height 0, base frame, mm
  Vec3 up{0, 0, 1};                                // plane normal (the heights go along it)
  std::vector<double> heights;                     // mm, >= 2 planes
  std::vector<std::vector<PixelPoint>> image;      // [plane][r * cols + c], px
  ImageSize imageSize;                             // the camera's frame size, px
  int maxSegments = 0;                             // <= 0: paper 001's ceil(m^(1/3))
};

struct MultiHeightFit {
  double rmsPx = 0, maxPx = 0;  // principal-curve fit: samples vs the curve at their height
};

// The k-segment fit residuals of the samples (paper 001, eq. (1)).
MultiHeightFit multiHeightFit(const MultiHeightSamples& samples);

Result<void> writeMultiHeight(const std::string& path, const MultiHeightSamples& samples);

struct MultiHeightCalibration {
  MultiHeightSamples samples;
  MultiHeightMap map;
  MultiHeightFit fit;
};
// maxFitPx: the largest fit RMS accepted (a worse file is NOT_CALIBRATED: recalibrate).
Result<MultiHeightCalibration> readMultiHeight(const std::string& path, double maxFitPx = 1.0);

}  // namespace vgr::vision::calib
