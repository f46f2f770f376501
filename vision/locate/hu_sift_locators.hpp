// Methods "hu" and "sift" of paper 002 (Sec. 4, identification), behind the Locator
// interface. Built by makeLocator(); see docs/localization.md for their parameters.
//
//   hu:   threshold (Otsu or fixed), findContours with hierarchy; each outer contour is
//         compared with the template's by matchShapes, the mean of I1, I2 and I3; the
//         template's inner contours (holes, dark marks) are then matched one-to-one to the
//         candidate's. The pose is the region's centroid (eq. 12) and its principal axis
//         (eq. 13), its 180-degree ambiguity resolved by agreement with the template region;
//         the grasp point follows.
//   sift: SIFT keypoints, FLANN kd-tree (5 trees, 10 checks), Lowe's ratio 0.7, at least 20
//         matches; a RANSAC homography per part (several parts: repeat on the matches left),
//         grasp point transferred through it.
#pragma once

#include <memory>

#include "core/result.hpp"
#include "vision/locate/locator.hpp"

namespace vgr::vision {

Result<std::unique_ptr<Locator>> makeHuLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);
Result<std::unique_ptr<Locator>> makeSiftLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);

}  // namespace vgr::vision
