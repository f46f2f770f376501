// Synthetic data for the depth-camera hand-eye calibration (vision/calib/handeye_cloud.hpp):
// the sphere target — spheres on posts over a plate — seen by a pinhole depth camera, as a
// z-depth image by exact ray casting (sphere and plane intersections, nearest hit), with
// Gaussian depth noise and the 16-bit quantisation of the 3D data-set format. This renders a
// calibration target only (like calib_scene.hpp's plates), not parts or bins.
// Pure functions of their arguments (seeded RNG); no I/O.
#pragma once

#include <cstdint>

#include <opencv2/core.hpp>

#include "core/depth.hpp"
#include "core/pose.hpp"
#include "vision/calib/intrinsics.hpp"
#include "vision/calib/sphere_target.hpp"

namespace vgr::sim {

struct DepthCamera {
  int width = 640, height = 480;                    // px
  DepthIntrinsics intrinsics{570.0, 570.0, 319.5, 239.5};
  double depthScaleMm = 0.05;                       // mm per unit of the 16-bit images
};
// A VGA time-of-flight / structured-light class camera (f = 570 px, 0.05 mm units).
DepthCamera defaultDepthCamera();

// Five spheres of 12.5 mm radius (25 mm balls) on posts 20-55 mm high over a plate, placed
// so that no rigid motion maps the set onto itself with another labelling.
vision::calib::SphereTarget defaultSphereTarget();
// The rectangle the target's plate and spheres stand on, as the plate spec whose corners
// span it (so sim/calib_scene.hpp's randomPlateViews keeps the target in view): 6 x 5 points,
// 30 mm pitch; the plate reaches one pitch beyond them.
vision::calib::PatternSpec sphereTargetFootprint();

struct DepthRenderOptions {
  double noiseSigmaMm = 0.3;  // Gaussian, along z, per pixel
  std::uint64_t seed = 1;
  bool plate = true;          // render the plate behind the spheres
};

// z in mm (CV_32FC1; 0 where the ray hits nothing) of the target at T_cam_target.
cv::Mat renderSphereTargetDepth(const DepthCamera& camera, const vision::calib::SphereTarget& target,
                                const vision::calib::PatternSpec& footprint, const Pose& camFromTarget,
                                const DepthRenderOptions& options);

// The 3D data-set image: round(z / depthScaleMm) as CV_16UC1; 0 (no data) stays 0 and a depth
// beyond the 16-bit range becomes 0.
cv::Mat quantiseDepth(const cv::Mat& depthMm, double depthScaleMm);

}  // namespace vgr::sim
