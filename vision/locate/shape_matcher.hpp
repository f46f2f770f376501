// Method "shape" (docs/shape-matcher.md): gradient-direction shape matching at any angle with sub-pixel
// pose refinement. The similarity is the mean normalised dot product of the model's and the
// image's gradient directions (Steger, "Occlusion, clutter, and illumination invariant object
// recognition", 2002, eq. 3; polarity variants eqs. 4-5), searched exhaustively over
// pre-rotated models only at the top of an image pyramid, with early termination against the
// minimum score, then tracked down the pyramid, interpolated in (x, y, theta) and refined by
// least squares on point-to-tangent distances. docs/shape-matcher.md has the algorithm, the
// parameters and the measured numbers.
//
// Threads: a ShapeLocator is used by one thread at a time; it spreads the top-level search
// over OpenCV's worker pool (cv::parallel_for_, TBB on Debian). Buffers are kept between
// calls: after the first image of a given size nothing of ours is allocated.
#pragma once

#include <memory>
#include <vector>

#include "core/result.hpp"
#include "vision/locate/locator.hpp"

namespace cv {
class Mat;
}

namespace vgr::vision {

enum class ShapePolarity {
  Use,           // image edges must have the template's dark/bright sense (eq. 3)
  IgnoreGlobal,  // the whole part may be inverted (eq. 4: |sum|)
  IgnoreLocal,   // each edge may be inverted on its own (eq. 5: sum of |.|)
};

// job.yaml parameters of method "shape" (TaughtTemplate::params), with their ranges.
struct ShapeParams {
  int levels = 0;               // pyramid levels incl. full resolution, [1, 7]; 0 = automatic
  double modelContrast = 15;    // gray levels/px, [1, 255]: template edges weaker than this are not model points
  double minContrast = 6;       // gray levels/px, [0, 255]: image gradients weaker than this count as no edge
  double greediness = 0.7;      // [0, 1]: 0 = safe early termination, 1 = greedy (fast, may miss)
  double angleStepDeg = 0;      // [0, 10]: full-resolution angle step; 0 = automatic (1 px at the model's rim)
  int maxPoints = 1500;         // [50, 20000]: model edge points kept at full resolution
  double maxOverlap = 0.3;      // [0, 1]: two results overlapping more than this (equivalent circles) are one part
  ShapePolarity polarity = ShapePolarity::Use;  // "polarity": use | ignore_global | ignore_local
  bool refine = true;           // least-squares refinement (else: peak interpolation only)
  int workers = 2;              // [1, 16]: stripes of the top-level search
  // Height-aware grasp (TaughtTemplate::regions, >= 2 of them): after the rigid fit the region
  // the grasp point lies on settles with its own translation within +-regionShiftPx under the
  // shared rotation, and the grasp point follows that region. 0 = off (one rigid pose).
  double regionShiftPx = 96;    // px, [0, 200]
};

// Where the time of a "shape" locate() call went (vgr-bench-locate --profile,
// docs/performance.md): wall time of the calling thread and CPU time of the whole process
// (every thread: the top-level search runs on OpenCV's pool), in ms, per stage.
struct ShapeStageTimes {
  enum Stage { Pyramid, TopGradient, TopSearch, Track, Refine, kCount };
  double wallMs[kCount] = {};
  double cpuMs[kCount] = {};
  static const char* name(int stage);
};

// The stage times of `locator`'s last locate() call; nullptr when it is not a "shape" locator.
// Same thread as locate().
const ShapeStageTimes* shapeStageTimes(const Locator& locator);

// Parses and range-checks TaughtTemplate::params for "shape"; errors name the parameter.
Result<ShapeParams> parseShapeParams(const TaughtTemplate& taught);

// The "shape" Locator for makeLocator(): builds the model from the template's edges.
// Errors (Status::BadArgument): a bad parameter, or a template without enough edges.
Result<std::unique_ptr<Locator>> makeShapeLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);

}  // namespace vgr::vision
