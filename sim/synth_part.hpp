// Synthetic images for the localization methods' tests and vgr-bench-features: a textured
// part drawn with OpenCV in its own "part canvas" (belt-plane pixels), optionally with raised
// layers (a boss and a rib) above the belt, placed into a scene by a known rotation +
// translation, seen by a pinhole camera looking straight down, so that raised layers away
// from the principal point shift outward by the projection difference of paper 000 (scale
// k = Hc / (Hc - h) about the principal point), plus Gaussian noise. (The cell's renderer of
// textured multi-height parts is sim/part_scene.hpp; these images are the ones the feature
// methods' test thresholds and the paper-001 Table 1 bench were measured on.)
//
// Conventions as vision/locate/locator.hpp: pixel centres at integers, y down, a pose's
// angle is counter-clockwise as displayed, (u, v) is where the part's grasp point (on the
// belt-level base layer) lands. Pure functions of their arguments and seeds.
#pragma once

#include <cstddef>
#include <cstdint>
#include <random>
#include <vector>

#include <opencv2/core.hpp>

#include "vision/locate/locator.hpp"

namespace vgr::sim::synth {

struct PartPose {
  double u = 0, v = 0;  // grasp point in the image, px
  double angleDeg = 0;  // counter-clockwise as displayed
};

struct PartLayer {
  cv::Mat texture;                 // CV_8U, canvas size
  cv::Mat alpha;                   // CV_8U, canvas size, 255 = covered
  std::vector<cv::Point> outline;  // canvas px
  double heightMm = 0;
};

struct SynthPart {
  cv::Size canvas;
  cv::Point2d grasp;              // canvas px, on the base layer
  std::vector<PartLayer> layers;  // base first, then raised layers by height
};

constexpr double kBackground = 30;       // belt gray level
constexpr double kCameraHeightMm = 600;  // principal point to belt

// A 320 x 220 px part: a plate with holes, texture and lettering; multiHeight adds a
// textured boss 30 mm high on the right and a rib 45 mm high along the top edge.
SynthPart makeTexturedPart(bool multiHeight);

// Canvas px -> image px of a layer at heightMm for a part at `pose`, camera principal
// point `pp` (paper 000's projection difference: k = Hc / (Hc - h) about pp).
cv::Mat layerWarp(const SynthPart& part, const PartPose& pose, double heightMm, cv::Point2d pp);

// Draws the parts into `image` (CV_8U, `size`), with Gaussian noise of `noiseSigma` gray levels.
cv::Mat renderScene(const SynthPart& part, const std::vector<PartPose>& poses, cv::Size size, double noiseSigma,
                    std::uint64_t seed);

// The template: the part at angle 0 with its grasp point at (margin + grasp), seen with the
// principal point at the template's centre (taught under the camera centre), no noise.
struct SynthTemplate {
  cv::Mat image;
  vision::PixelPoint grasp;
  std::vector<vision::TemplateRegion> regions;  // raised layers first (height factor small), base last
};

SynthTemplate makeTemplate(const SynthPart& part, int margin = 30, double raisedHeightFactor = 0.05);

// Random poses with the grasp point away from the border (angle in +-maxAngleDeg).
PartPose randomPose(std::mt19937& rng, cv::Size size, double maxAngleDeg);

// Three non-overlapping poses (one per third of the image width).
std::vector<PartPose> threePoses(std::mt19937& rng, cv::Size size, double maxAngleDeg);

double angleDiffDeg(double a, double b);

// The match true-positive rate of paper 001 (Table 1) for accepted matches of a part at
// `truth`: a match is true when its image point is within tolPx of where the template
// point lands on the belt plane (raised-layer matches shift by the projection difference
// and count as false).
double matchTruePositiveRate(const std::vector<vision::MatchPair>& matches, const PartPose& truth,
                             vision::PixelPoint templateGrasp, double tolPx = 3.0);

// A scene without the part: belt, noise and a textured distractor (a different pattern).
cv::Mat renderDistractorScene(cv::Size size, double noiseSigma, std::uint64_t seed);

// Index of the truth pose nearest to (u, v).
size_t nearestPose(const std::vector<PartPose>& poses, double u, double v);

}  // namespace vgr::sim::synth
