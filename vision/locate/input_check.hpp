// The input every taught locator checks before its method runs (makeLocator wraps each
// method in it), so that an image a method cannot search is named for what it is:
//   "shape: the 80x60 px image is smaller than the 200x150 px template"
//   "shape: the search ROI 1000,900 300x200 lies outside the 640x480 px image"
//   "shape: expected a non-empty 8-bit gray image, got an empty image" (resp. "3 channels")
// An image smaller than the template in both directions cannot hold the taught view; a
// ROI partly outside is clipped to the image as before. Same thread rules as the wrapped
// locator.
#pragma once

#include <memory>

#include <opencv2/core.hpp>

#include "core/taught_template.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::vision {

std::unique_ptr<Locator> withInputChecks(std::unique_ptr<Locator> method, cv::Size templateSize, PixelRect searchRoi);

}  // namespace vgr::vision
