// The scene renderer: a flat part on a dark conveyor at a pose drawn from (seed, frame id),
// seen by a pinhole camera. Ground truth is a pure function of (seed, frame id), so a test
// that knows the emulator's seed and a cycle's frame id (journal field "frame_id") knows
// where the part was: SceneRenderer::truthForFrame(). No I/O, no global state.
#pragma once

#include <cstdint>
#include <vector>

#include "vision/calib/plane_model.hpp"

namespace cv {
class Mat;
}

namespace vgr::config {
struct CellConfig;
}

namespace vgr::sim {

struct PointMm {
  double x = 0, y = 0;
};

struct SceneTruth {
  std::uint64_t frameId = 0;
  double xMm = 0, yMm = 0, zMm = 0;  // part origin (its area centroid = grasp point), base frame
  double rzDeg = 0;                  // part +x axis about base z, (-180, 180]
  double uPx = 0, vPx = 0;           // the same point in the image
  double angleImgDeg = 0;            // part +x axis in the image, counter-clockwise as displayed
};

struct SceneOptions {
  int width = 1280, height = 1024;  // px
  double noiseSigma = 2.0;          // gray levels, Gaussian
  std::uint64_t seed = 1;
  int marginPx = 160;               // the grasp point stays this far from the image border
  std::uint8_t background = 30;     // conveyor gray level
  std::uint8_t foreground = 200;    // part gray level
  // Commissioning (cell.yaml sim.still / sim.fiducial, docs/commissioning.md): with
  // stillFrame > 0 every frame shows the part where frame `stillFrame` has it (the noise
  // still changes with the frame id); a fiducial (diameter > 0) is a bright disk lying on
  // the plane at a fixed base-frame position, drawn into every frame.
  std::uint64_t stillFrame = 0;
  double fiducialXMm = 0, fiducialYMm = 0, fiducialDiameterMm = 0;  // mm
  std::uint8_t fiducialGray = 230;
};

class SceneRenderer {
 public:
  SceneRenderer(const vision::PinholePlaneModel& model, SceneOptions options);
  // The camera that renders (`model`) differs from the nominal one the parts are placed by
  // (`placement`): a camera moved after calibration (cell.yaml sim.camera_shift).
  SceneRenderer(const vision::PinholePlaneModel& model, SceneOptions options, const vision::PinholePlaneModel& placement);

  // The simulated cell of a cell config: its `model` section is the true camera, `sim` the rest.
  static SceneRenderer fromCellConfig(const config::CellConfig& cell);

  // Where the part is in frame `frameId` (deterministic in seed and frame id; with
  // stillFrame set, where it is in that frame).
  SceneTruth truthForFrame(std::uint64_t frameId) const;

  // Renders frame `frameId` into `dst` (CV_8UC1, width x height; reallocated only if its
  // size differs) and returns its truth. Thread-safe (const, no shared state).
  SceneTruth render(std::uint64_t frameId, cv::Mat& dst) const;

  // The same frame as render() as 16-bit gray (CV_16UC1, each 8-bit level v as v * 257, so
  // full scale is 65535), for Mono16 cameras. `scratch` is the 8-bit render target (reused).
  SceneTruth render16(std::uint64_t frameId, cv::Mat& dst, cv::Mat& scratch) const;

  // Renders a given truth (for tests that choose the pose themselves).
  void renderTruth(const SceneTruth& truth, std::uint64_t noiseSeed, cv::Mat& dst) const;

  // Part outline in the part frame, mm, area centroid at the origin, +x toward the tip.
  static const std::vector<PointMm>& partOutlineMm();

  const SceneOptions& options() const { return options_; }
  const vision::PinholePlaneModel& model() const { return model_; }

 private:
  vision::PinholePlaneModel model_;
  SceneOptions options_;
  vision::PinholePlaneModel placement_;
};

}  // namespace vgr::sim
