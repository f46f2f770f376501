// Writes a 3D data set in the fixed format (docs/3d.md "Data-set format") from the depth
// renderer (sim/depth_scene.hpp), for `vgr sim render --3d`:
//   DIR/camera.yaml, DIR/images/NNNN.png (16-bit z), DIR/truth.csv (+ part, face, pixels,
//   visible_pixels), DIR/model.ply (exterior points + normals, 1 mm grid), DIR/mesh.ply
//   (exterior triangles, edges <= 1.5 mm), DIR/views/view_NN.png + views/views.csv (when
//   views > 0), DIR/dataset.yaml (the options it was made with), and with `grasps` the
//   grasp ground truth DIR/grasps.csv (config/grasp_truth_file.hpp, sim/grasp_truth.hpp).
// Nothing half-written: the files go to DIR.partial-PID, renamed to DIR at the end; DIR must
// not exist (or be an empty folder). Start-up style I/O, one thread.
#pragma once

#include <string>

#include "core/result.hpp"
#include "sim/depth_scene.hpp"

namespace vgr::sim {

struct DepthDatasetOptions {
  std::string outDir;
  int count = 100;            // [1, 1000000] scenes
  DepthSceneOptions scene;
  int views = 12;             // [0, 72] model-building views (0 = no views folder)
  PartViewsOptions viewOptions;  // part, camera, sensor and seed come from `scene`
  double modelSpacingMm = 1;  // model.ply grid
  double meshEdgeMm = 1.5;    // mesh.ply triangle edges
  bool grasps = false;        // also write grasps.csv
};

struct DepthDatasetSummary {
  int images = 0, emptyImages = 0, parts = 0, views = 0;
};

// Errors: Status::BadArgument (an option out of range, DIR not empty), Status::Internal (a
// file that cannot be written; the partial folder is removed).
Result<DepthDatasetSummary> writeDepthDataset(const DepthDatasetOptions& options);

}  // namespace vgr::sim
