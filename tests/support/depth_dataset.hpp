// A small 3D data set for the depth-camera tests (the fixed format of issue 13,
// config/depth_dataset.hpp), made without the 3D renderer: the sphere calibration
// target (sim/depth_calib_scene.hpp) at a few poses in front of the default depth camera,
// 0.3 mm noise, 16-bit at 0.05 mm per unit. truth.csv gives each image's target pose in the
// camera frame ("model frame" = the target frame); the last image is empty (no part) when
// `withEmpty`. Test thread; writes only under `dir`.
#pragma once

#include <string>
#include <vector>

#include "core/pose.hpp"

namespace vgr::test {

struct DepthTestSet {
  std::string dir;
  std::vector<std::string> images;       // relative to dir, name order ("images/0000.png", ...)
  std::vector<std::vector<Pose>> truth;  // per image: the target's pose in the camera frame (none when empty)
  int width = 0, height = 0;
  double depthScaleMm = 0;
};

// Fails the current test (and returns what was written) on any I/O error.
DepthTestSet writeDepthTestSet(const std::string& dir, int images, unsigned seed = 1, bool withEmpty = true);

}  // namespace vgr::test
