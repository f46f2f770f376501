// The analytic baseline grasp detector (docs/grasp.md "Analytic baseline"): no model of the
// parts, only geometry.
//   1. heights above the fitted floor (vision/grasp/height_map.hpp);
//   2. objects: pixels at least minObjectHeightMm high once the pixels without data have
//      taken their lower neighbour's height (vision/grasp/height_map.hpp fillHolesLow: the
//      sensor drops both sides of every depth jump, which would cut an object into its
//      faces), opened with a 3 x 3 square (specks of noise go), 8-connected components of
//      at least minObjectAreaPx pixels whose highest point stays below maxObjectHeightMm
//      (bin walls and fixtures are not grasped);
//   3. each object's minimum-area oriented box (cv::minAreaRect) in the image; the grasp
//      closes across its short side at the box centre, opening = short side + 2 clearances,
//      kept when that fits the gripper;
//   4. highest object first (the top of a pile is the least covered).
// Every grasp it returns has quality 1: the baseline has no notion of confidence.
// Threads: any, one call at a time per detector.
#pragma once

#include <memory>

#include "vision/grasp/grasp_detector.hpp"

namespace vgr::vision::grasp {

Result<std::unique_ptr<GraspDetector>> makeAnalyticDetector(const GraspDetectorOptions& options);

}  // namespace vgr::vision::grasp
