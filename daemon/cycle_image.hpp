// What a cycle's sinks see of its frame (daemon/cycle_runner.hpp CycleSinks::onResult):
// the image archive and the page (daemon/web_page.hpp) draw from it. Valid during the
// onResult call only (a view of the cycle thread's buffers); a sink that keeps it copies.
#pragma once

#include <opencv2/core.hpp>

#include "core/depth.hpp"
#include "core/pose.hpp"

namespace vgr::daemon {

struct CycleImage {
  // A 2D cycle: the 8-bit gray image the locator was given (CV_8UC1). A 3D cycle: the depth
  // frame it located in (CV_32FC1, z in mm, 0 = no data; `depth` true). Empty when the cycle
  // had no usable frame.
  cv::Mat image;
  bool depth = false;
  // A depth frame's pinhole intrinsics and T_base_cam of this frame (mm; eye-in-hand: the
  // trigger's T_base_flange * X), so a picture can draw each part's pose:
  // T_cam_grasp = T_base_cam^-1 * PartResult::pose.
  DepthIntrinsics intrinsics;
  Pose baseFromCamera;
};

}  // namespace vgr::daemon
