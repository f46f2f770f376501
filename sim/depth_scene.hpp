// Depth scenes with ground truth (docs/3d.md "Renderer"): the public interface of the depth
// renderer, for `vgr sim render --3d`, the GigE depth camera emulator and tests.
//
//   renderDepthScene(options, index)  one bin scene: parts of one kind on any stable face,
//       random yaw, tilted up to tiltMaxDeg, among clutter in a bin (or on a table), seen
//       from above by a pinhole depth camera -> 16-bit z image + intrinsics + per-part truth
//   renderPartViews(options)          the part alone on a table from several viewpoints, with
//       the camera's pose in the model frame, true and as a robot would report it (noisy):
//       the input of model building (paper 004 Sec. 3.1)
//
// Frames and units: camera frame x right, y down, z forward (mm); a part's truth is the pose
// of its model frame in the camera frame (T_cam_model, mm + unit quaternion, qw >= 0), the
// frame of sim/depth_parts.hpp's meshes. Deterministic in (options.seed, index); no I/O, no
// shared state: any thread.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core/mat.hpp>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "sim/depth_render.hpp"

namespace vgr::sim {

struct DepthSceneOptions {
  std::string part = "bracket";  // a depthPartNames() name
  DepthCameraModel camera;       // 640 x 480, f = 800 px: 0.7 mm per pixel on the bin floor
  DepthSensorOptions sensor;
  int partsPerScene = 1;         // [0, 8] parts of the kind per non-empty scene (fewer if they do not fit)
  double emptyRatio = 0;         // [0, 1] share of scenes without a part
  int clutter = 6;               // [0, 32] distractor boxes and cylinders, never touching a part
  double tiltMaxDeg = 20;        // [0, 60] each part tilted about a random horizontal axis by up to this
  bool bin = true;               // bin walls (100 mm high) around a 380 x 280 mm floor; false: a table
  double floorMm = 560;          // [200, 5000] camera centre to the floor along the optical axis
  double cameraTiltMaxDeg = 5;   // [0, 30] the camera looks down tilted by up to this
  // [0, 0.95]: a board held above the first part hides this share of the pixels the part
  // covers (the "mostly hidden part" scene); 0 = none.
  double occlusion = 0;
  // Every part rests on this stable face ("-z": its natural one, as depth_parts.hpp names
  // them); "" = any stable face, drawn per part.
  std::string face;
  // Another viewpoint of the same scene (eye-in-hand snapshots): the camera moved to T_cam_view
  // in the frame of the camera the scene is drawn for; the scene itself does not change.
  // Identity: that camera. Truth is given in the moved camera's frame.
  Pose view;
  std::uint64_t seed = 1;
};

struct DepthPartTruth {
  Pose pose;                 // T_cam_model, mm + unit quaternion (qw >= 0)
  std::string face;          // the stable face it rests on ("-z", "+x", ...)
  int pixels = 0;            // pixels it would cover alone in this view
  int visiblePixels = 0;     // pixels where it is the nearest surface (before sensor effects)
};

struct DepthScene {
  cv::Mat depth;             // CV_16UC1: v * camera.depthScaleMm = z mm; 0 = no data
  cv::Mat labels;            // CV_16UC1: 1 + part index where a part is nearest; 0 anything else
  cv::Mat exactZ;            // CV_64FC1: exact z of the nearest surface (mm, +inf where none), before
                             // the sensor: the grasp truth's jaw checks (sim/grasp_truth.hpp)
  DepthCameraModel camera;
  std::vector<DepthPartTruth> parts;  // empty = a scene without a part
};

// Errors: Status::BadArgument for an unknown part or an option out of its range.
Result<DepthScene> renderDepthScene(const DepthSceneOptions& options, std::uint64_t index);

struct PartViewsOptions {
  std::string part = "bracket";
  DepthCameraModel camera;
  DepthSensorOptions sensor;
  int views = 12;                 // [3, 72] on a circle around the part, elevations alternating
  double distanceMm = 450;        // [150, 2000] camera centre to the part's centroid
  double elevationLowDeg = 40;    // (0, 90) odd views' camera elevation above the table
  double elevationHighDeg = 65;   // (0, 90) even views'
  double poseNoiseMm = 1;         // [0, 100] reported pose: each axis off by U(-n, n) mm
  double poseNoiseDeg = 0.5;      // [0, 45] reported pose: rotated by U(-n, n) deg about each axis
  int badView = -1;               // a view whose reported position is off by badViewMm more; -1 = none
  double badViewMm = 20;          // [0, 1000] in a random direction
  std::uint64_t seed = 1;
};

struct PartView {
  cv::Mat depth;       // CV_16UC1 as in DepthScene
  Pose cameraInModel;  // T_model_cam, true
  Pose reported;       // T_model_cam as a robot would report it (noise, the bad view's offset)
};

// The part rests on its natural face (-z down) on a 400 x 400 mm table; each camera looks at
// the part's centroid. Errors: Status::BadArgument as above.
Result<std::vector<PartView>> renderPartViews(const PartViewsOptions& options);

}  // namespace vgr::sim
