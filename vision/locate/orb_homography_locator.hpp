// Methods "orb-ransac" and "orb-prosac": the feature-matching baselines that papers 000
// (section IV, "RANSAC feature points matching") and 001 (Table 1, RANSAC and PROSAC rows)
// compare against. ORB features, paper 001's coarse matching (FLANN both ways, T = mu*minD,
// symmetric check), then one robust homography: cv::RANSAC, or cv::USAC_PROSAC (OpenCV's
// USAC PROSAC sampler over the matches sorted by descriptor distance). The grasp point goes
// through the homography (paper 001, eq. 15); the angle is the homography's rotation there.
#pragma once

#include <memory>

#include "core/result.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::vision {

Result<std::unique_ptr<Locator>> makeOrbRansacLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);
Result<std::unique_ptr<Locator>> makeOrbProsacLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);

}  // namespace vgr::vision
