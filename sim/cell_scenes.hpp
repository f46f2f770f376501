// What the simulated camera of a cell config shows, and where the parts were: the one place
// the camera emulator, `vgr demo` and the tests get frames and ground truth from.
//
// `sim.scene: plate` (default) is the skeleton's flat plate (SceneRenderer, one part per
// frame, Otsu-friendly); `part` and `multi` are the dataset renderer's textured parts
// (PartSceneRenderer: holes, printed marks, machining grain; `multi` with 2-4 height
// levels), so that every localization method, the feature ones included, can run in the
// simulated cell. In every mode a frame is a pure function of (config, frame id).
// Commissioning keys (docs/commissioning.md): `sim.still` keeps the parts of frame 1 in
// every frame (only the noise changes), `sim.camera_shift` renders through a camera moved
// from `model` (parts stay where the nominal camera placed them), `sim.fiducial` draws a
// fixed bright disk on the belt.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "sim/part_scene.hpp"
#include "sim/scene.hpp"

namespace vgr::sim {

// One part of a frame: its grasp point in the base frame (mm) and in the image (px), its
// rotation about base z, and the image direction of its +x axis (CCW as displayed).
struct CellPartTruth {
  double xMm = 0, yMm = 0, zMm = 0, rzDeg = 0;
  double uPx = 0, vPx = 0, angleImgDeg = 0;
  int label = 0;  // sim.classes: the part's 1-based class index there; 0 without classes
};

class CellScenes {
 public:
  explicit CellScenes(const config::CellConfig& cell);

  int width() const;
  int height() const;
  const std::string& mode() const { return mode_; }

  // Parts in frame `frameId` (none: an empty belt), in the renderer's order.
  std::vector<CellPartTruth> truth(std::uint64_t frameId) const;
  // Frame `frameId` into dst (CV_8UC1, reallocated only if its size differs); returns truth(frameId).
  std::vector<CellPartTruth> render(std::uint64_t frameId, cv::Mat& dst) const;
  // One JSON object (no newline) of a frame's truth: {"frame_id", the first part's fields at
  // the top level (x_mm, y_mm, z_mm, rz_deg, u_px, v_px, angle_img_deg), "parts": [...]};
  // a part of a scene with sim.classes also has "label".
  static std::string truthJson(std::uint64_t frameId, const std::vector<CellPartTruth>& parts);

  // part/multi only (null for plate): the renderer, for teaching a job on its template.
  const PartSceneRenderer* partRenderer() const { return parts_.get(); }

 private:
  std::string mode_;
  std::unique_ptr<SceneRenderer> plate_;
  std::unique_ptr<PartSceneRenderer> parts_;
  double planeZ_ = 0;
  bool still_ = false;  // sim.still: every frame shows frame 1's parts
  bool labelled_ = false;  // sim.classes given: truth carries labels
};

// The image angle (CCW as displayed) of the base frame's +x axis for the cell's camera: what
// a job taught on a part at rz = 0 puts in `angle_offset_deg` (docs/localization.md).
double baseXAxisImageAngleDeg(const config::CellConfig& cell);

}  // namespace vgr::sim
