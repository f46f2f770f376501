// Multi-height (nonlinear parallel-plane) calibration of paper 001 (section 4.1, eqs. 1-8):
// the robot touches a grid of points (13 x 15 in the paper) on parallel planes every few mm
// above the conveyor; each grid point's image positions across the heights are fitted with a
// k-segment principal curve, which gives the grid's image positions at any height; a pixel is
// mapped at height h by locating it in that interpolated grid (inverse bilinear per cell).
// No camera model at all: lens distortion is absorbed by the grid, to the extent the grid
// is dense enough. Pure geometry; const methods are thread-compatible.
#pragma once

#include <optional>
#include <vector>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/calib/plane_model.hpp"

namespace vgr::vision::calib {

// One polyline (u, v) as a function of the height h: vertices at heights knotH (sorted),
// image positions knotUv. Paper 001 fits the curve by minimising the squared distance of the
// samples to it (eqs. 1, 3, 8), adding a vertex at the middle of the segment holding the
// most samples until k ~ m^(1/3) segments. Here each sample's projection onto the curve is
// its own height (the robot's heights are known exactly), so for a fixed vertex set the fit
// is linear least squares on hat functions.
struct PrincipalCurve {
  std::vector<double> knotH;
  std::vector<PixelPoint> knotUv;
  PixelPoint at(double h) const;  // linear inside, extrapolated from the end segments outside
};

// samplesH: the heights (mm, at least 2, any order); samplesUv: the image points at them.
// maxSegments <= 0: ceil(m^(1/3)) as in paper 001.
PrincipalCurve fitKSegmentCurve(const std::vector<double>& samplesH, const std::vector<PixelPoint>& samplesUv,
                                int maxSegments = 0);

class MultiHeightMap {
 public:
  // gridBase[r * cols + c]: the touched point at height 0 (base frame, mm); it moves by h
  // along the plane normal `up` at height h. heights: the planes (mm). image[k][r * cols + c]:
  // where grid point (r, c) was seen at heights[k]. Errors name the inconsistent sizes.
  static Result<MultiHeightMap> build(int rows, int cols, const std::vector<Vec3>& gridBase, Vec3 up,
                                      const std::vector<double>& heights,
                                      const std::vector<std::vector<PixelPoint>>& image, int maxSegments = 0);

  // Base-frame point seen at pixel p on the plane at height h. Empty outside the grid.
  std::optional<Vec3> pixelToRobot(PixelPoint p, double heightMm) const;

  int segments() const { return segments_; }  // k of the first curve (all use the same rule)
  int rows() const { return rows_; }
  int cols() const { return cols_; }

 private:
  int rows_ = 0, cols_ = 0, segments_ = 0;
  std::vector<Vec3> grid_;
  Vec3 up_;
  std::vector<PrincipalCurve> curves_;
};

}  // namespace vgr::vision::calib
