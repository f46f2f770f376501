// The "shape" method's model: sub-pixel edge points of the template with their unit gradient
// directions, one set per pyramid level, plus the image-side gradient helpers the model and
// the search share. Internal to vision/locate (shape_matcher.cpp); not a public contract.
#pragma once

#include <vector>

#include "core/result.hpp"
#include "vision/locate/shape_matcher.hpp"

namespace cv {
class Mat;
}

namespace vgr::vision::shape {

// Edge points of one pyramid level, relative to the model origin, in that level's pixels
// (x right, y down). Struct of arrays so the search loops vectorise.
struct LevelModel {
  std::vector<float> x, y;    // px from the origin
  std::vector<float> nx, ny;  // unit gradient direction (dark -> bright)
  double radius = 0;          // px: largest |(x, y)|
  double angleStep = 0;       // rad: the search step at this level (1 px at the rim)
  int size() const { return static_cast<int>(x.size()); }
};

struct Model {
  // Every level of the template's pyramid that has >= 8 edge points ([0] = full resolution);
  // the search uses levels [0, searchLevels). Levels beyond the search's top serve parts seen
  // smaller than taught (templateLevel()).
  std::vector<LevelModel> levels;
  int searchLevels = 1;
  PixelPoint origin;               // template px of the level-0 origin (the edge points' centroid)

  // The template level whose detail matches image level `level` for a part seen at `scale`
  // (image px per template px): the part's pixels there are 2^level / scale template px, so
  // the level round(level + log2(1 / scale)), within [0, levels.size() - 1]. Its points,
  // times scale * 2^(L - level), are the part's edges at that image level.
  int templateLevel(int level, double scale) const;
};

// Builds the model. levels = 0 picks the level count automatically: the highest level at
// which the part, at the smallest scale searched (scaleMin, image px per template px), still
// has >= 24 points and a radius >= 8 px (so a 1-px shift at the rim is still an angle step of
// at most ~7 deg).
Result<Model> buildModel(const cv::Mat& templ, const ShapeParams& params, double scaleMin = 1.0);

// Gradient of an 8-bit image as gray levels per pixel: Sobel 3x3 scaled by 1/8 (CV_32F).
// With smooth = true a Gaussian (sigma 1 px) is applied first: the sub-pixel edge estimator
// uses that (a smoother peak profile, less bias in the parabola fit).
void gradient(const cv::Mat& src8, cv::Mat& gx, cv::Mat& gy, bool smooth, cv::Mat& scratch);

// Sub-pixel offset t (px, along n) of the maximum of f(t) = s * n . grad(p + t n) within
// [-range, range], sampled every 0.5 px with bilinear interpolation and refined by a parabola
// through the best sample and its neighbours. s = +1 for edges of the model's sense, -1 for
// inverted ones; absPolarity uses |n . grad|. Returns false when there is no interior
// maximum of at least minMag. gx, gy: CV_32F maps; p in their pixel coordinates.
bool edgeAlongNormal(const cv::Mat& gx, const cv::Mat& gy, double px, double py, double nx, double ny, double range,
                     double s, bool absPolarity, double minMag, double& t, double& mag);

}  // namespace vgr::vision::shape
