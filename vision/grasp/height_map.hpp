// The floor (table or bin floor) under the parts in a depth image, and every pixel's height
// above it (docs/grasp.md "Input"): the common first step of both grasp detectors.
//   fitFloorPlane    RANSAC over a grid of the image's valid points (deterministic: fixed
//                    seed), then a least-squares refit on the inliers; the largest plane is
//                    taken as the floor, so it must cover a good share of the view
//   heightAboveFloor every pixel's distance to that plane, toward the camera
// Frames and units: camera frame x right, y down, z forward (mm); depth images CV_32FC1 z in
// mm with 0 = no data (vision/depth_image.hpp). Pure code, any thread.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "core/result.hpp"

namespace vgr::vision::grasp {

// Pinhole intrinsics of the depth camera (the data set's camera.yaml), px.
struct DepthIntrinsics {
  int width = 0, height = 0;
  double fx = 0, fy = 0, cx = 0, cy = 0;
};

// The plane n . p = offset (camera frame, mm), n a unit vector pointing toward the camera
// (n.z < 0): a point's height above the floor is n . p - offset.
struct FloorPlane {
  double nx = 0, ny = 0, nz = -1, offset = 0;
  double inlierShare = 0;  // of the valid grid points, within inlierMm of the plane
  double rmsMm = 0;        // RMS distance of the inliers after the refit
  // z of the plane along the principal ray (pixel (cx, cy)), mm.
  double depthAtPrincipalPoint() const { return offset / nz; }
};

struct FloorOptions {
  int gridStepPx = 4;        // [1, 64] every n-th pixel in x and y is a candidate point
  int iterations = 300;      // [10, 100000] RANSAC hypotheses
  double inlierMm = 2.5;     // (0, 100] inlier distance
  double minInlierShare = 0.2;  // (0, 1] fewer inliers: no floor found
};

// Errors (Status::BadArgument, `name` first): not a CV_32FC1 image of the intrinsics' size,
// too few valid pixels, no plane holding minInlierShare of them, a plane seen edge-on.
Result<FloorPlane> fitFloorPlane(const cv::Mat& zMm, const DepthIntrinsics& camera, const std::string& name,
                                 const FloorOptions& options = {});

// CV_32FC1 height above the floor in mm; NaN where the depth image has no data.
cv::Mat heightAboveFloor(const cv::Mat& zMm, const DepthIntrinsics& camera, const FloorPlane& floor);

// CV_8UC1: 255 where a height map has data (not NaN), 0 elsewhere. (OpenCV's `h == h` and
// `h != h` are not reliable for NaN across its SIMD paths: measured, `h != h` found none.)
cv::Mat hasData(const cv::Mat& heightMm);

// Fills pixels without data (NaN) with the lowest of their 8-neighbours that have data,
// `passes` times (a band up to 2 * passes px wide closes). A hole at a depth jump belongs to
// the surface behind: the lower side. Returns how many pixels are still NaN.
int fillHolesLow(cv::Mat& heightMm, int passes);

// The camera-frame point of pixel (u, v) at depth z (mm).
cv::Point3d backProject(const DepthIntrinsics& camera, double u, double v, double zMm);

// Median of the valid depths (> 0) in the (2 r + 1)^2 window at (u, v); 0 when none.
double depthNear(const cv::Mat& zMm, double u, double v, int r = 2);

}  // namespace vgr::vision::grasp
