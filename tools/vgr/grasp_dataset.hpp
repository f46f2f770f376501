// A 3D data set with grasp ground truth (`vgr sim render --3d --grasps`, docs/grasp.md) as
// the grasp commands read it: camera.yaml, and grasps.csv grouped by image in file order.
// Offline tool code, one thread.
#pragma once

#include <string>
#include <vector>

#include "config/grasp_truth_file.hpp"
#include "core/result.hpp"
#include "vision/grasp/grasp_detector.hpp"
#include "vision/grasp/grasp_metrics.hpp"

namespace vgr::tools {

struct GraspImage {
  std::string image;                              // relative to the data set, e.g. images/0000.png
  std::vector<config::GraspTruthRow> grasps;      // empty: nothing graspable in it
};

struct GraspDataset {
  std::string folder;
  vision::grasp::DepthIntrinsics camera;
  double depthScaleMm = 0;
  std::vector<GraspImage> images;
};

// Errors: camera.yaml's or grasps.csv's (file:line; a grasp centre outside camera.yaml's
// image too), "DIR/grasps.csv: cannot open" with a hint to render with --grasps.
Result<GraspDataset> loadGraspDataset(const std::string& folder);

// The image's depth in mm (vision/depth_image.hpp's checks: 16-bit, camera.yaml's size).
Result<vision::grasp::DepthFrame> loadGraspFrame(const GraspDataset& set, const GraspImage& image);

// The image's true rectangles for scoring; polylines number (part, grasp) pairs.
std::vector<vision::grasp::TruthRect> truthRects(const GraspDataset& set, const GraspImage& image);

}  // namespace vgr::tools
