// The search parameters of a 3D job (docs/3d.md "Parameters"): plain data shared by config/
// (job.yaml `search:` is read into it, with ranges and file:line:key errors) and
// vision/cloud/ (the 3D locator is built from it). No Open3D, no YAML. Units: mm, degrees;
// the ROI box is in the camera frame (x right, y down, z forward).
//
// Paper 004 Sec. 3.2 / 5: n_R rotated copies of the model, FPFH + RANSAC then ICP; accept
// above f_h, refine and re-check between f_l and f_h, below f_l "retry from a new viewpoint".
#pragma once

#include <string>
#include <vector>

namespace vgr {

struct RoiBox {
  double xMin = -1e5, xMax = 1e5;  // mm, camera frame
  double yMin = -1e5, yMax = 1e5;
  double zMin = 1, zMax = 1e5;     // mm along the optical axis
};

struct Search3dParams {
  double voxelMm = 3;           // [0.5, 50] FPFH / RANSAC voxel (normals radius 2 v, FPFH radius 5 v)
  int nRotations = 8;           // [1, 36] paper's n_R: model copies turned by 2 pi / n_R about its z axis
  // [0, 1] paper's f_l: below it the view is not good enough (retry). 0.7, not lower: on 12
  // empty cluttered scenes a clutter fit with fitness 0.60 was accepted at 0.5 (docs/3d.md).
  double fLow = 0.7;
  double fHigh = 0.85;          // [f_l, 1] paper's f_h: above it a candidate is accepted at once
  int maxParts = 1;             // [1, 64] parts per scene (found ones are removed, then search again)
  RoiBox roi;                   // points outside are ignored
  bool removePlane = true;      // remove the dominant plane (table, bin floor) before matching
  double planeDistanceMm = 2;   // [0.1, 50] plane inliers
  double planeMinShare = 0.3;   // [0, 1] the plane is removed only if it holds this share of the points
  double featureRadiusMm = 30;  // [1, 200] FPFH neighbourhood (at most 100 neighbours)
  // [0, 500] views of the model its features are computed on (docs/3d.md "Features"); 0 =
  // FPFH of the whole model and Open3D's RANSAC as paper 004 does (ransacConfidence applies)
  int modelViews = 40;
  // [0, 100] Euclidean clusters (DBSCAN radius) of the scene after plane removal; each
  // cluster of plausible size is registered on its own (docs/3d.md "Clusters"); 0 = the
  // whole scene at once (the paper's pipeline)
  double clusterMm = 8;
  int featureNeighbours = 1;    // [1, 10] model features matched per scene point (k nearest in FPFH space)
  int ransacIterations = 20000; // [100, 1e7] per rotated copy (per cluster with clusterMm > 0)
  double ransacConfidence = 0.999;  // (0, 1] early stop of Open3D's RANSAC (modelViews = 0 only)
  double ransacDistanceMm = 15;     // [0.5, 100] distance checker of our RANSAC loop
  double edgeSimilarity = 0.8;      // [0, 1) edge-length checker (Open3D's, 1 = equal edges)
  int hypothesesPerCopy = 3;        // [1, 20] best RANSAC hypotheses refined by ICP per copy
  double icpDistanceMm = 2;     // [0.2, 50] correspondences of the final point-to-plane ICP
  int icpIterations = 30;       // [1, 1000] per ICP stage
  double fitnessDistanceMm = 2.5;  // [0.2, 50] a model point "is seen" when the measured z is this close
  double maxContradiction = 0.08;  // [0, 1] share of the model's visible points where the sensor sees through it
  double retryMinFitness = 0.1;    // [0, f_l] a consistent candidate at least this good below f_l asks for a new view
  // [0, 1000] no model point may lie farther than this beyond the removed plane (table, bin
  // floor): a part rests on it (docs/3d.md "Evidence"); applies only when a plane was removed
  double maxBelowPlaneMm = 5;
  double visibleMaxAngleDeg = 70;  // [1, 89] model points seen more obliquely count neither way
  int threads = 1;              // [1, 64] OpenMP threads Open3D may use
  unsigned seed = 1;            // RANSAC's random seed (each locate call is deterministic)
};

// The numeric parameters by their job.yaml key (under `search:`), with their ranges: the one
// table the job reader (config/job3d.cpp) and the locator's check (vision/cloud) use.
// `roi`, `remove_plane` and `seed` are read on their own.
struct Search3dKey {
  const char* name;  // e.g. "voxel_mm"
  double lo, hi;     // inclusive
  bool integer;
  double (*get)(const Search3dParams&);
  void (*set)(Search3dParams&, double);
};
const std::vector<Search3dKey>& search3dKeys();

// The checks between fields: f_h >= f_l, retry_min_fitness <= f_l, ROI min < max on every
// axis and z_max > 0. Empty when fine, else "KEY: what" (KEY as in job.yaml, e.g. "f_h").
std::string search3dCrossCheck(const Search3dParams& p);

}  // namespace vgr
