// Method "orb-adk" (paper 001, section 4.2): ORB (FAST-9) features; FLANN matching in both
// directions with T = mu * minD (mu = 5) and the symmetric check; PROSAC; then the ADK
// filter: distance-difference and angle-difference vectors to the most credible match
// (eqs. 11-14), seeded clustering with 5 px / 3 degree class bounds, k-means from those
// seeds, the dominant cluster kept; a homography from the kept matches and the grasp point
// through it (eq. 15).
#pragma once

#include <memory>

#include "core/result.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::vision {

Result<std::unique_ptr<Locator>> makeOrbAdkLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);

}  // namespace vgr::vision
