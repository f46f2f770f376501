// A calibration target for depth cameras: spheres of one known radius at known centres,
// seen as a point cloud (paper 003 registers "corner clouds"; with a depth camera the
// cloud's points are the sphere centres, found with sub-millimetre accuracy from hundreds of
// depth pixels each). Used by the point-cloud hand-eye calibration (handeye_cloud.hpp).
//
// Frames: target frame as in target.yaml (mm); camera frame x right, y down, z forward (mm).
// Pure geometry: no threads, no I/O except target.yaml.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/depth.hpp"
#include "core/pose.hpp"
#include "core/result.hpp"

namespace vgr::vision::calib {

struct SphereTarget {
  double radiusMm = 0;        // every sphere's radius, mm (> 0)
  std::vector<Vec3> centres;  // target frame, mm (validateSphereTarget)
};

// At least 4 spheres, radius in (0, 500] mm, centres at least 2.5 radii apart (they must
// not touch in any view), not all on one line. Whether a view can be labelled without
// ambiguity is checked per view (matchSphereTarget). Errors name what is wrong.
Result<void> validateSphereTarget(const SphereTarget& target);

// target.yaml (OpenCV FileStorage): calibration_kind "sphere_target", radius_mm, centres_mm
// (n x 3). Errors name the file and key.
Result<void> writeSphereTarget(const std::string& path, const SphereTarget& target);
Result<SphereTarget> readSphereTarget(const std::string& path);

struct SphereFindOptions {
  double maxRmsMm = 1.0;          // a fit whose radial RMS is above this is not a sphere
  double radiusTolerance = 0.1;   // the free-radius fit must be within this share of the radius
  double minCoverage = 0.3;       // inlier pixels / the pixels a whole hemisphere would cover
  int normalStepPx = 3;           // depth-gradient half-baseline for the normals, px
};

struct SphereDetection {
  Vec3 centre;           // camera frame, mm (least squares with the target's radius)
  double rmsMm = 0;      // RMS of |p - centre| - radius over the inliers
  double freeRadiusMm = 0;  // radius of a fit with the radius free (a check of the object)
  int inliers = 0;       // depth pixels used
};

// Spheres of `radiusMm` in a depth image (CV_32FC1, z in mm, 0 = no data). Each depth pixel
// with a normal (from the depth gradient) votes for a centre one radius behind its surface;
// clusters of votes are refined by Gauss-Newton on the radial residuals of the pixels within
// 2 mm of the sphere, and accepted by coverage, RMS and the free-radius check. Strongest
// first. Not finding any is not an error (an empty list).
std::vector<SphereDetection> findSpheres(const cv::Mat& depthMm, const DepthIntrinsics& intrinsics, double radiusMm,
                                         const SphereFindOptions& options = {});

// The spheres of one view labelled with the target's: every injective assignment of the
// detections to the target's centres is tried (at least 4 detections), the best rigid fit
// (Kabsch) wins if its RMS is below maxRmsMm and clearly better than the runner-up. Errors
// name why (too few spheres, no fit, ambiguous).
struct TargetView {
  std::vector<int> ids;        // target index of each point
  std::vector<Vec3> points;    // camera frame, mm (the detections' centres)
  Pose camFromTarget;          // T_cam_target from the rigid fit
  double fitRmsMm = 0;         // RMS of the fit
};
Result<TargetView> matchSphereTarget(const std::vector<SphereDetection>& found, const SphereTarget& target,
                                     double maxRmsMm = 2.0);

// Least-squares rigid transform T with T * from[i] ~ to[i] (Kabsch/Umeyama without scale).
// At least 3 points not on a line.
Pose rigidFit(const std::vector<Vec3>& from, const std::vector<Vec3>& to);

}  // namespace vgr::vision::calib
