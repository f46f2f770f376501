// Depth images of the 3D data sets and of depth cameras (docs/3d.md): a 16-bit single-channel
// z image where a value v is v * depthScaleMm mm and 0 means "no data", converted to the
// locator's input, CV_32FC1 z in mm with 0 = no data (vision/cloud/locator3d.hpp). Pure image
// code, any thread.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "core/result.hpp"

namespace vgr::vision {

// Reads PATH as it is stored (no conversion) and checks it is a depth image of the expected
// size holding at least one valid pixel. Errors (Status::BadArgument), one line each:
//   "PATH: cannot read the image"
//   "PATH: a depth image must be 16-bit single-channel; this one is 8-bit, 3 channels"
//   "PATH: 320x240 px, but camera.yaml says 640x480"    (when width/height > 0)
//   "PATH: no valid depth pixel (every value is 0)"
Result<cv::Mat> readDepthMm(const std::string& path, double depthScaleMm, int width = 0, int height = 0);

// The same checks on an image in memory (CV_16UC1) -> mm; `name` is used in the messages.
Result<cv::Mat> depthToMillimetres(const cv::Mat& depth16, double depthScaleMm, const std::string& name, int width = 0,
                                   int height = 0);

}  // namespace vgr::vision
