// 3D part localization (paper 004 Sec. 3.2 and 5; docs/3d.md): finds a part model in a depth
// image and returns a six-degree-of-freedom pose per part with a typed outcome. The public
// entry point for vgrd's cycle thread and the `vgr` tool. Plain header: no Open3D types
// (Open3D stays inside vision/cloud/*.cpp, behind vision/cloud/open3d_backend.hpp).
//
// Input: z in millimetres (cv::Mat CV_32FC1, 0 = no data) and the pinhole intrinsics of that
// image (px, pixel centres at integers). Output poses: the model frame in the camera frame
// (T_cam_model; camera x right, y down, z forward; mm + unit quaternion, qw >= 0), the
// convention of the 3D data sets' truth.csv.
//
// Outcomes (how a robot or PLC sees them: docs/3d.md "Outcomes"):
//   Found                  >= 1 part accepted (fitness >= f_h, or >= f_l after refinement)
//   NotFound               nothing part-like: no candidate consistent with the view
//   RetryFromNewViewpoint  paper 004's failure below f_l: a candidate consistent with the
//                          view (the sensor nowhere sees through it) but covering less than
//                          f_l of what this viewpoint should show - too much hidden; move
//                          the camera and try again
// A wrong pose is worse than none: every accepted part passed the consistency check.
//
// Thread: a Locator3d is used by one thread at a time (it keeps scratch buffers); build it
// at start-up (create() prepares the model's features). Open3D's OpenMP threads are bounded
// by params.threads on every call.
#pragma once

#include <memory>
#include <string_view>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/depth.hpp"
#include "core/pose.hpp"
#include "core/result.hpp"
#include "core/search3d.hpp"
#include "vision/ply_file.hpp"

namespace vgr::vision::cloud {

// Pinhole intrinsics of one depth image size (core/depth.hpp); the locator needs width and
// height stated and equal to the depth image's.
using DepthIntrinsics = vgr::DepthIntrinsics;

enum class Outcome3d { Found, NotFound, RetryFromNewViewpoint };
// "found", "not_found", "retry_new_viewpoint"
std::string_view outcomeName(Outcome3d o);

struct Part3d {
  Pose pose;                 // T_cam_model, mm + unit quaternion
  Pose grasp;                // T_cam_grasp = T_cam_model * T_model_grasp
  double fitness = 0;        // [0, 1] share of the points this view should show of the model that it does show
  double contradiction = 0;  // [0, 1] share where the sensor sees through the model
  double rmseMm = 0;         // RMS point-to-plane residual of the final ICP
  double score = 0;          // = fitness
  int rotationCopy = 0;      // which of the n_R model copies it came from
  bool refined = false;      // accepted between f_l and f_h after refinement
};

struct Locate3dResult {
  Outcome3d outcome = Outcome3d::NotFound;
  std::vector<Part3d> parts;     // best first
  double bestOtherFitness = 0;   // best candidate not accepted (0 if none)
  std::string reason;            // why NotFound / Retry (for logs and `vgr locate`)
  int scenePoints = 0;           // points left after ROI and plane removal (voxelised)
  int candidates = 0;            // RANSAC + ICP runs
};

class Locator3d {
 public:
  virtual ~Locator3d() = default;
  // depthMm: CV_32FC1 of intrinsics' size. Errors (Status::BadArgument): wrong type or size,
  // no valid pixel, intrinsics not positive.
  virtual Result<Locate3dResult> locate(const cv::Mat& depthMm, const DepthIntrinsics& intrinsics) = 0;
  virtual const Search3dParams& params() const = 0;
};

// Builds the locator from a model cloud (mm, model frame, with normals) and the grasp pose in
// the model frame (T_model_grasp). Errors (Status::BadArgument): a model without normals or
// with fewer than 100 points, parameters out of range (message names the parameter).
Result<std::unique_ptr<Locator3d>> makeLocator3d(const PlyCloud& model, const Pose& graspInModel, const Search3dParams& params);

// The same range checks the job loader applies, for callers that build params in code.
Result<void> checkSearch3dParams(const Search3dParams& p);

}  // namespace vgr::vision::cloud
