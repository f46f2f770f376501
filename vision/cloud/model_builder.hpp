// Part models from depth views (paper 004 Sec. 3.1; docs/3d.md "Model building"): depth
// views of the part alone on a table, each with the camera's pose in the model frame as a
// robot reports it (approximate), become one merged model cloud with outward normals in
// that frame - what `vgr model build` writes into a 3D job. Plain header (no Open3D types);
// start-up style work, one thread at a time.
//
// Steps:
//   1. per view: back-projection (mm, camera frame), the table removed (the dominant
//      plane by RANSAC and everything beyond it), the largest Euclidean cluster kept (the
//      part), voxel grid, normals turned towards the camera (= outward);
//   2. every pair of views registered by point-to-plane ICP (eq. 2), started from the
//      reported poses, coarse to fine; an edge is kept when enough of the source overlaps
//      the target (fitness) with a small residual (RMSE);
//   3. pose graph over the kept edges, odometry edges (view i to i+1) certain, the others
//      loop closures that the global optimisation may prune (Sec. 3.1, [32, 34]); views
//      the kept edges do not connect to the largest connected set are left out;
//   4. the optimised poses aligned to the reported ones in the least-squares sense (every
//      kept view's points, Umeyama): the model frame is the reported poses' frame, with the
//      robot's noise averaged over the views instead of taken from one;
//   5. a robot pose that disagrees with the registration: per view, the RMS distance of its
//      points between its reported and its registered pose. The worst view over
//      maxPoseDisagreementMm has a wrong reported pose (or is not a view of this part): its
//      edges are rejected with that reason, the view is left out (a wrong view would bend
//      the model; leaving it out costs one view of coverage) and steps 3-5 run again;
//   6. every kept view's points in that frame, merged, voxel grid (modelVoxelMm), normals
//      re-estimated with their outward orientation kept; the bottom closed (closeBottom):
//      an open model fits a scene upside down as well as the right way up, and the 3D
//      locator then returns wrong poses;
//   7. per view: fitness and RMSE of its points against the model.
// Nothing is returned when fewer than minViews views are kept: the error says which views
// were left out and why.
#pragma once

#include <functional>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/depth.hpp"
#include "core/pose.hpp"
#include "core/result.hpp"
#include "vision/ply_file.hpp"

namespace vgr::vision::cloud {

struct ModelView {
  std::string name;        // for the report (the view's file name)
  cv::Mat depthMm;         // CV_32FC1 z in mm, 0 = no data, of intrinsics' size
  DepthIntrinsics intrinsics;
  Pose reported;           // T_model_cam as the robot reported it (mm, unit quaternion)
};

struct ModelBuildParams {
  double viewVoxelMm = 1.5;              // (0, 20] per-view grid for registration
  double modelVoxelMm = 1.0;             // (0, 20] grid of the merged model (of every part pixel of every view)
  double tableDistanceMm = 2.0;          // (0, 50] plane inlier band; points beyond the plane go too
  double clusterGapMm = 4.0;             // (0, 100] Euclidean clustering: points closer are one object
  double icpStartMm = 12.0;              // (0, 200] first ICP pass's pairing distance; halved to icpFinalMm
  double icpFinalMm = 1.5;               // (0, icpStartMm]
  double minFitness = 0.3;               // [0, 1] share of the source paired with the target
  double maxRmseMm = 1.0;                // (0, 20]
  double maxPoseDisagreementMm = 10.0;   // (0, 1000] see step 5
  double edgePruneThreshold = 0.25;      // (0, 1] Open3D's line-process threshold for loop closures
  int minViews = 3;                      // [2, ...] views needed in the model
  // The face the part rests on, never seen, closed: the part's outline on the table plane
  // becomes its bottom (right for parts whose outline seen from above is where they touch
  // the table; an overhang gets a bottom it does not have). See step 6.
  bool closeBottom = true;
  int threads = 1;                       // [1, 64] Open3D's OpenMP threads
};

struct ModelEdgeReport {
  int source = 0, target = 0;            // view indices
  bool odometry = false;                 // target = source + 1
  double fitness = 0, rmseMm = 0;        // of the final ICP pass
  double disagreementMm = 0;             // RMS move of the source's points against the reported poses
  bool kept = false;
  std::string why;                       // when not kept: "low overlap (fitness 0.12 < 0.3)", ...
};

struct ModelViewReport {
  std::string name;
  int points = 0;                        // after table removal and the grid
  bool used = false;
  std::string why;                       // when not used
  double poseDisagreementMm = 0;         // RMS move of its points from the reported to the registered pose (step 3)
  double fitness = 0, rmseMm = 0;        // against the final model (used views)
  Pose registered;                       // T_model_cam as the registration puts it (used views)
};

struct ModelBuildResult {
  PlyCloud model;                        // model frame, mm, outward unit normals
  std::vector<ModelViewReport> views;
  std::vector<ModelEdgeReport> edges;
  int viewsUsed = 0;
  int bottomPoints = 0;                  // points of the closed bottom (closeBottom)
};

// progress(done, total, what) is called as the work goes on (may be empty).
// Errors (Status::BadArgument): parameters out of range (names the parameter), fewer than
// minViews views, a view whose depth image does not match its intrinsics or has no part
// left after the table removal (names the view), too few views kept (names each left-out
// view and why).
Result<ModelBuildResult> buildModel(const std::vector<ModelView>& views, const ModelBuildParams& params,
                                    const std::function<void(int, int, const std::string&)>& progress = {});

// How close a model lies to a true surface (`vgr model eval --mesh`): the model is first
// aligned to the mesh by point-to-plane ICP from its pose as given (one rigid alignment,
// pairing distance alignMm), then for every model point its exact distance to the nearest
// mesh triangle. Errors (Status::BadArgument): an empty model or mesh.
struct MeshDistance {
  double meanMm = 0, p95Mm = 0, maxMm = 0;
  int points = 0;
  Pose alignment;                        // mesh <- model: the rigid alignment applied
};
Result<MeshDistance> modelToMeshDistance(const PlyCloud& model, const PlyMesh& mesh, double alignMm = 3.0);

}  // namespace vgr::vision::cloud
