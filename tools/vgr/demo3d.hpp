// `vgr demo --3d` (docs/demo.md "3D"): what the simulated 3D cell needs besides the processes
// the 2D demo starts, and how its poses are scored.
//   prepareDemo3d  writes WORK/sim-cell-3d.yaml, WORK/sim-calib-3d/{handeye,truth}.yaml and
//                  WORK/sim-job-3d/job.yaml (embedded from config/examples/), renders
//                  WORK/scenes (the depth renderer: the demo's scene choice below) and copies
//                  its model.ply into the job folder. Returns the config's path.
//   Truth3d        the part poses the depth emulator served per frame (its --truth file,
//                  T_cam_model), turned into the robot base frame with the TRUE camera pose
//                  (the calibration set's truth.yaml, not the calibrated one) and the job's
//                  grasp: T_base_grasp = X_true * T_cam_model * T_model_grasp.
// The scenes: one part (config/examples/sim-job-3d's part) lying on the bin floor on any
// stable face, no clutter, no tilt, the camera tilted up to 5 deg: what the localizer finds
// today (docs/3d.md "Measured" has its recall in cluttered bins). Start-up style; one thread.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include "core/pose.hpp"
#include "core/result.hpp"

namespace vgr::tools {

// Every 3D pose within these of the truth, or the demo exits 1 (issue 14's bounds).
inline constexpr double kDemo3dMaxPosErrMm = 1.0;
inline constexpr double kDemo3dMaxRotErrDeg = 1.0;

// The demo's scenes (what docs/demo.md states).
struct Demo3dScenes {
  std::string part = "housing";
  int clutter = 0;
  double tiltMaxDeg = 0;
  double cameraTiltMaxDeg = 5;
  bool bin = true;          // in the bin (walls in view)
  std::string face;         // any stable face
  double emptyRatio = 0;   // tests: scenes without a part (NO_PART_FOUND)
  double occlusion = 0;    // tests: a board hiding this share of the part (RETRY_NEW_VIEWPOINT)
};

// Errors: Status::BadArgument (a file that cannot be written, the renderer's errors).
Result<std::string> prepareDemo3d(const std::string& work, int scenes, std::uint64_t seed,
                                  const Demo3dScenes& choice = Demo3dScenes{});

class Truth3d {
 public:
  // Reads WORK/sim-calib-3d/truth.yaml, WORK/sim-job-3d/job.yaml and the emulator's truth
  // file (one JSON line per served frame). Errors name the file.
  static Result<Truth3d> load(const std::string& work, const std::string& truthJsonl);
  // T_base_grasp of every part of the frame; empty when the frame is unknown or has no part.
  std::vector<Pose> baseGrasps(std::uint64_t frameId) const;

 private:
  Pose baseFromCamera_;
  Pose modelFromGrasp_;
  std::map<std::uint64_t, std::vector<Pose>> camFromModel_;
};

}  // namespace vgr::tools
