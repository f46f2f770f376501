// Model building from depth views (paper 004 Sec. 3.1, eqs. 1-3; docs/3d.md "Model
// building"): depth views of the part alone on a table, each with the camera's pose in the
// model frame as a robot reports it -> one point cloud with normals in that frame.
//
//   1 each view -> points in the camera frame; the table (the dominant plane) and everything
//     beyond it removed; points farther than cropRadiusMm from the model-frame origin and
//     isolated points (statistical outliers) dropped; into the model frame by the reported pose
//   2 pairwise point-to-plane ICP (eq. 2) between views that overlap (odometry: consecutive
//     views; loop closures: any two whose viewing directions are within 75 deg); an edge is
//     rejected when its overlap (fitness) is below minFitness, its RMSE above maxRmseMm, or ICP
//     moved one view against the other by more than maxCorrectionMm / maxCorrectionDeg
//     (the robot's poses are good to ~1 mm / 0.5 deg: a larger correction means one of the
//     two poses is wrong, or ICP slid)
//   3 a pose graph over the views with the accepted edges, globally optimised (Open3D's
//     multiway registration [32, 34]: Levenberg-Marquardt with a line process that may prune
//     loop closures); the result re-anchored to the reported poses (the rigid motion that best
//     maps the optimised camera centres onto the reported ones), so the model stays in the
//     frame the poses are given in
//   4 the views merged (eq. 3), voxelised to voxelMm (points and normals averaged), outliers
//     removed
// A view whose every edge was rejected is left out (the report says so).
//
// Pure computation (no I/O); one thread; Open3D's OpenMP threads bounded by `threads`.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/cloud/locator3d.hpp"
#include "vision/ply_file.hpp"

namespace vgr::vision::cloud {

struct ModelView {
  std::string name;      // for the report
  cv::Mat depthMm;       // CV_32FC1, z in mm, 0 = no data
  DepthIntrinsics intrinsics;
  Pose cameraInModel;    // T_model_cam as reported
};

struct ModelBuildParams {
  double registrationVoxelMm = 1.5;  // [0.5, 20] views are registered at this voxel
  double voxelMm = 1.0;              // [0.2, 20] the model's voxel
  double tableDistanceMm = 3;        // [0.5, 50] points this close to the table (or beyond it) go
  double cropRadiusMm = 150;         // [10, 5000] around the model-frame origin
  double icpDistanceMm = 3;          // [0.5, 50] ICP correspondences (coarse; fine = half)
  double minFitness = 0.3;           // [0, 1] edge: share of the source view's points paired
  double maxRmseMm = 1.5;            // [0.05, 50] edge: RMS distance of the pairs
  double maxCorrectionMm = 4;        // [0.1, 500] edge: ICP's correction of the reported relative pose
  double maxCorrectionDeg = 3;       // [0.1, 180]
  double loopClosureMaxAngleDeg = 75;  // [0, 180] views looking this alike get an edge
  int threads = 1;                   // [1, 64]
};

struct ModelEdgeReport {
  int source = 0, target = 0;     // view indices
  bool odometry = false;          // consecutive views (else a loop closure)
  double fitness = 0, rmseMm = 0;
  double correctionMm = 0, correctionDeg = 0;
  bool accepted = false;
  bool prunedByOptimisation = false;
  std::string reason;             // why rejected / pruned; empty when kept
};

struct ModelViewReport {
  std::string name;
  int points = 0;                 // after table removal and cropping
  bool used = false;              // in the model
  double rmseMm = 0;              // RMS distance to the model of its points (within 3 mm), after optimisation
  double correctionMm = 0, correctionDeg = 0;  // optimised pose vs reported
  std::string reason;             // why left out
};

struct ModelBuildResult {
  PlyCloud model;                 // model frame, mm, with normals
  std::vector<ModelEdgeReport> edges;
  std::vector<ModelViewReport> views;
};

// progress(done, total, stage) is called as the pairs are registered and the stages pass.
// Errors (Status::BadArgument): fewer than 2 views, a view of another type or size than its
// intrinsics, parameters out of range, no view left with an accepted edge.
Result<ModelBuildResult> buildModel(const std::vector<ModelView>& views, const ModelBuildParams& params,
                                    const std::function<void(int, int, const std::string&)>& progress = nullptr);

// `vgr model eval` (docs/3d.md): the distance of a model's points to a triangle mesh after one
// rigid alignment (point-to-plane ICP of the model onto points sampled on the mesh, from the
// identity: the model is expected in the mesh's frame). Exact point-to-triangle distances.
struct ModelEvalResult {
  int points = 0;
  double meanMm = 0, p95Mm = 0, maxMm = 0;
  double alignmentMm = 0, alignmentDeg = 0;  // the rigid alignment applied
};
Result<ModelEvalResult> evaluateModel(const PlyCloud& model, const PlyMesh& mesh, int threads = 1);

}  // namespace vgr::vision::cloud
