// Rendered scenes with ground truth for the localization benchmark (vgr-bench-locate) and the
// shape matcher's unit tests: a down-looking pinhole camera over the conveyor, the sim part at
// a chosen image position and rotation, a template cut from a rendering of the part. On top
// of SceneRenderer (which stays the one source of pixels and truth). Millimetres and degrees
// as sim/scene.hpp; pure functions of their arguments and seeds.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "sim/scene.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::sim {

// A camera `heightMm` above the plane looking straight down, focal length fPx: the part
// (100 mm long) is about 100 * fPx / heightMm px long.
SceneRenderer makeRenderer(int width, int height, double fPx, double heightMm, double noiseSigma,
                           std::uint64_t seed = 1);

// The truth of a part whose centroid is at image (u, v) and whose +x axis shows at
// angleImgDeg (CCW as displayed).
SceneTruth truthAt(const SceneRenderer& r, double u, double v, double angleImgDeg);

// The centroid of what the renderer actually drew for `t`: the coverage-weighted centroid of a
// noise-free rendering (coverage from the conveyor's known shading and the part's gray level).
// SceneRenderer's anti-aliasing (8x supersampled fillPoly) places the drawn part up to ~0.06 px
// away from SceneTruth::uPx/vPx (measured, docs/performance.md), the same order as the shape
// matcher's error: the benchmark reports errors against both.
vision::PixelPoint drawnCentroid(const SceneRenderer& r, const SceneTruth& t);

struct SceneTemplate {
  cv::Mat image;                  // CV_8UC1 crop
  SceneTruth truth;               // of the full rendering it was cut from
  vision::PixelPoint grasp;       // the part's centroid, template px
  vision::PixelPoint graspDrawn;  // the drawn part's centroid (drawnCentroid), template px
};

// The part at the image centre at angleImgDeg, cut out with `marginPx` around its outline.
SceneTemplate makeSceneTemplate(const SceneRenderer& r, double angleImgDeg, int marginPx, std::uint64_t noiseSeed);

}  // namespace vgr::sim
