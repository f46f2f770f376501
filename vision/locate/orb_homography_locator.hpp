// Methods "orb-ransac" and "orb-prosac": the feature-matching baselines that papers 000
// (section IV, "RANSAC feature points matching") and 001 (Table 1, RANSAC and PROSAC rows)
// compare against. ORB features, paper 001's coarse matching (FLANN both ways, T = mu*minD,
// symmetric check), then one robust homography: cv::RANSAC, or cv::USAC_PROSAC (OpenCV's
// USAC PROSAC sampler over the matches sorted by descriptor distance). The grasp point goes
// through the homography (paper 001, eq. 15); the angle is the homography's rotation there.
//
// Their input: paper 001 does not describe the baselines' matching separately. It runs its
// comparison "with the parameters of the algorithm consistent" (section 5.1), and section 5.3
// (Fig. 13) shows PROSAC working on "the putative correspondence sets [established] using
// the Flann algorithm", i.e. the coarse matching of section 4.2 (T = mu * minD, symmetric
// check). So the baselines take that same coarse stage by default and differ from orb-adk
// only in the filter; `symmetric_matching: false` gives them plain FLANN nearest neighbours
// (template -> image) instead, the common textbook baseline.
#pragma once

#include <memory>

#include "core/result.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::vision {

Result<std::unique_ptr<Locator>> makeOrbRansacLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);
Result<std::unique_ptr<Locator>> makeOrbProsacLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);

}  // namespace vgr::vision
