// The depth renderer's two stages (docs/3d.md "Renderer"), for sim/depth_scene.cpp and tests:
//   rasterize()    an exact pinhole z-buffer: for every pixel centre (integers, x right, y
//                  down) the z of the nearest triangle hit by the pixel's ray, computed by
//                  intersecting the ray with the triangle's plane (no interpolation error);
//   applySensor()  what a structured-light / stereo sensor makes of it: invalid pixels at
//                  grazing angles and depth jumps, Gaussian noise growing with z^2, random
//                  dropout, quantisation to the 16-bit step.
// Camera frame: x right, y down, z forward (the optical axis), mm. Pure code, no I/O; any
// thread (no shared state).
#pragma once

#include <cstdint>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/pose.hpp"
#include "sim/depth_parts.hpp"

namespace vgr::sim {

// Pinhole intrinsics of a depth camera and its 16-bit encoding (the data-set's camera.yaml).
struct DepthCameraModel {
  int width = 640, height = 480;             // px
  double fx = 800, fy = 800;                 // px
  double cx = 319.5, cy = 239.5;             // px, pixel centres at integers
  double depthScaleMm = 0.1;                 // a 16-bit value v is v * depthScaleMm mm of z; 0 = no data
};

struct DepthSensorOptions {
  double noiseMmAt500 = 0.3;  // [0, 10] sigma of z at z = 500 mm; sigma(z) = noise * (z / 500)^2
  double dropout = 0.01;      // [0, 1) share of otherwise valid pixels with no data
  double jumpMm = 3;          // (0, inf) a pixel whose exact z differs from an 8-neighbour's by more is invalid
  double grazingDeg = 78;     // (0, 90] a surface seen more obliquely than this (ray vs normal) is invalid
};

// One mesh placed in the camera frame: camera <- mesh (T_cam_mesh), and the label its pixels
// get in the label image (0 is "nothing").
struct MeshInstance {
  const TriMesh* mesh = nullptr;
  Pose pose;
  std::uint16_t label = 0;
};

// The exact render: z (CV_64FC1, mm, +inf where no triangle), the cosine between the ray and
// the surface normal (CV_32FC1, 0 where none) and the label of the nearest surface (CV_16UC1).
struct ExactDepth {
  cv::Mat z, cosine, labels;
};

// Triangles with a vertex closer than 1 mm to the camera plane are skipped (never in our scenes).
void rasterize(const std::vector<MeshInstance>& meshes, const DepthCameraModel& camera, ExactDepth& out);

// The sensor's 16-bit image (CV_16UC1) from an exact render; deterministic in `seed`.
// The quantisation step is camera.depthScaleMm; z beyond 65535 steps is "no data".
cv::Mat applySensor(const ExactDepth& exact, const DepthCameraModel& camera, const DepthSensorOptions& sensor,
                    std::uint64_t seed);

// 16-bit depth -> z in mm (CV_32FC1, 0 = no data): the locator's input (vision/cloud/).
cv::Mat depthToMm(const cv::Mat& depth16, double depthScaleMm);

}  // namespace vgr::sim
