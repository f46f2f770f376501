// The grasp network's input and output geometry (docs/grasp.md "Input"), shared by the
// detector (vision/grasp/ggcnn_detector.cpp) and the training-data export (`vgr grasp
// tensors`), so training and inference see exactly the same tensor.
//   1. heights above the fitted floor (vision/grasp/height_map.hpp), NaN where no data;
//   2. resized to kNetMmPerPx on the floor (scale = floor depth / fx / kNetMmPerPx rounded
//      to 1/32, 0.5 for the simulated camera: 640 x 480 -> 320 x 240), averaging only
//      valid pixels;
//   3. holes filled with the lowest valid neighbour (a hole at a depth jump belongs to the
//      surface behind), repeated kFillPasses times, then 0 (the floor);
//   4. divided by kHeightScaleMm and clamped to [-1, 2];
//   5. padded (replicating the border) to multiples of kNetStride.
// Network px <-> image px: image = (net + 0.5) / scale - 0.5 per axis (pixel centres at
// integers; the sizes are rounded, so the two axes' scales may differ by < 1 px / size).
// Pure code, any thread.
#pragma once

#include <array>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.hpp"
#include "vision/grasp/height_map.hpp"

namespace vgr::vision::grasp {

constexpr double kNetMmPerPx = 1.4;      // input resolution on the floor
constexpr double kHeightScaleMm = 50;    // input = height / this
constexpr int kNetStride = 12;           // the network's total stride (3 * 2 * 2)
constexpr int kFillPasses = 4;
constexpr double kNetWidthScalePx = 50;  // the width map holds opening px (network scale) / this

struct NetInput {
  cv::Mat tensor;      // CV_32FC1, rows and cols multiples of kNetStride
  int rows = 0, cols = 0;  // the part of `tensor` that holds the image (the rest is padding)
  double scaleX = 1, scaleY = 1;  // network px per image px: cols / image cols, rows / image rows
};

// The scale for a floor: floor depth at the principal point / fx / kNetMmPerPx, rounded to
// 1/32. Error (Status::BadArgument, `name` first) when it falls outside [1/8, 1]: the camera
// sees the floor so coarsely (or finely) that the input cannot be made at kNetMmPerPx, and
// the network would see parts at a size it was not trained on.
Result<double> netScale(const DepthIntrinsics& camera, const FloorPlane& floor, const std::string& name);

// heightMm: CV_32FC1 (heightAboveFloor()), NaN = no data.
NetInput makeNetInput(const cv::Mat& heightMm, double scale);

inline double netToImage(double x, double scale) { return (x + 0.5) / scale - 0.5; }
inline double imageToNet(double x, double scale) { return (x + 0.5) * scale - 0.5; }

// A true grasp rectangle (image px) for the training targets: one sampled centre of a line
// of true centres sampled every stepMm.
struct TargetGrasp {
  double u = 0, v = 0, angleDeg = 0, widthPx = 0;
  double pxPerMm = 1;   // image px per mm at the grasp's depth (fx / z)
  double stepMm = 2;    // to the next sampled centre of the same grasp
};

constexpr double kTargetSigmaMm = 2;  // the quality target's width across the line of centres

// The training targets of one image on the network's grid, after GG-CNN (Morrison et al.
// 2018) with a Gaussian quality: quality = exp(-d^2 / 2 sigma^2), d the distance to the line
// of true centres (each sample covering +- stepMm / 2 along it), sigma = kTargetSigmaMm, so a
// thin section peaks as high and as sharp as a wide one (GG-CNN marks the middle third of each
// rectangle: a wide block's plateau would outbid a thin arm's); where the quality is >= 0.01,
// cos 2 theta, sin 2 theta and opening (network px) / kNetWidthScalePx of the grasp with the
// highest quality there, 0 elsewhere. Four CV_32FC1 maps of in.tensor's size.
std::array<cv::Mat, 4> drawNetTargets(const std::vector<TargetGrasp>& grasps, const NetInput& in);

}  // namespace vgr::vision::grasp
