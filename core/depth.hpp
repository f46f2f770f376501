// Depth frames as the 3D code sees them: z in mm per pixel (CV_32FC1 where an image type is
// needed, 0 = no data) with the pinhole intrinsics of that image. This is the contract
// between the depth camera drivers (drivers/), the replay and emulator cameras and the 3D
// consumers (vision/cloud's locator, the point-cloud hand-eye calibration). Plain values.
#pragma once

namespace vgr {

// Pinhole intrinsics of a depth image, px: x right, y down, pixel centres at integers, so a
// pixel (u, v) with depth z mm is the camera-frame point ((u - cx) z / fx, (v - cy) z / fy, z)
// (x right, y down, z forward). One type for the drivers, the data sets, the calibration and
// vision/cloud's locator (which checks width/height against the image it is given).
struct DepthIntrinsics {
  double fx = 0, fy = 0;      // px, > 0
  double cx = 0, cy = 0;      // px
  int width = 0, height = 0;  // px, the image size they belong to; 0 = not stated
};

}  // namespace vgr
