// Method "contour-weighted" (paper 000, section III): binary segmentation of the image into
// part candidates; per candidate ORB features matched by brute force and filtered with a
// unilateral grid constraint and the match distance error of eq. (2), giving the initial
// rotation theta_init and displacement d_init; then the template's gradient contour, split
// into regions weighted by their distance to the grasp point and their height factor
// (eqs. 3-4), is matched by the gradient-direction similarity of eq. (5) over
// theta_init +- r and d_init +- l (eq. 6) and accepted above sigma (eq. 7).
#pragma once

#include <memory>

#include "core/result.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::vision {

Result<std::unique_ptr<Locator>> makeContourWeightedLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);

}  // namespace vgr::vision
