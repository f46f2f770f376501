// Dataset scenes for the localization methods (docs/datasets.md): flat parts and parts with 2-4 height
// levels (a base plate with ribs and bosses, each an extruded polygon), projected through a
// pinhole camera looking straight down, so that raised features shift radially away from
// the image centre the farther the part is from it (paper 000's "projection difference",
// Sec. I and Fig. 1). Several parts per image (never overlapping), clutter, illumination
// gradient, blur, noise and images without a part.
//
// Ground truth per part: the grasp point (a 3D point on the part, at its grasp height)
// projected into the image, and the rotation relative to the template (the same part
// rendered under the optical axis at rz = 0), counter-clockwise as displayed.
//
// Pure image code, no I/O. A PartSceneRenderer is immutable after construction; render()
// is const and may be called from several threads at once.
#pragma once

#include <cstdint>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include "core/result.hpp"
#include "sim/scene.hpp"  // PointMm
#include "vision/calib/plane_model.hpp"

namespace cv {
class Mat;
}

namespace vgr::config {
struct CellConfig;
}

namespace vgr::sim {

using Polygon = std::vector<PointMm>;  // part frame, mm, closed implicitly

// One extruded level of a part: its top face is `outline` at `topMm` above the conveyor
// plane; its walls run from `baseMm` (the top of what it stands on) to `topMm`.
struct PartLayer {
  Polygon outline;
  double baseMm = 0, topMm = 0;  // mm above the conveyor plane, baseMm <= topMm
  std::uint8_t gray = 180;       // top face gray level before lighting
  std::vector<Polygon> marks;    // printed / engraved dark marks on the top face
  std::vector<Polygon> holes;    // through holes: the belt shows through
};

struct PartModel {
  std::string name;               // "flat" or "multi"
  std::vector<PartLayer> layers;  // sorted by topMm
  PointMm grasp;                  // grasp point, part frame, mm
  double graspHeightMm = 0;       // height of the grasp point above the plane, mm
  double radiusMm = 0;            // bounding radius of every layer about the part origin, mm

  // The skeleton's 100 x 50 mm pointed plate (SceneRenderer::partOutlineMm()), 0 mm thick,
  // with two holes and printed marks; grasp point 20 mm from the centroid toward the tip.
  static PartModel flat();
  // A 130 x 90 mm base plate (8 mm) with `levels` - 1 raised features on it: a rib (20 mm),
  // a round boss (35 mm, grasped at its centre), a square block (50 mm). levels in [2, 4].
  static PartModel multi(int levels);
  // The part classes `vgr sim render --classes` mixes (docs/classification.md): "flat" (the
  // part above) and 8 mm thick plates (paper 002's parts were 8 mm thick, Sec. 3) in
  // pairs of look-alikes that differ in one feature: "disc" (80 mm) / "ring" (the same disc
  // with a 30 mm hole) / "hex" (80 mm across corners: compactness), "square" (70 mm) /
  // "square_small" (60 mm: size only), "rect" (100 x 50 mm) / "rect_notch" (the same with a
  // 20 x 15 mm notch in one long side: solidity). Grasp at the outline's centroid.
  static Result<PartModel> byName(const std::string& name);
  static const std::vector<std::string>& classNames();
};

struct PartSceneOptions {
  int width = 1280, height = 1024;  // px
  double cameraHeightMm = 500;      // optical centre above the conveyor plane, mm
  double cameraXMm = 0, cameraYMm = 0;  // optical centre over the plane (base frame), mm
  double cameraRzDeg = 0;           // image x axis turned about base z (the sim cell's mount)
  double cxPx = -1, cyPx = -1;      // principal point, px; negative = the image centre
  double focalPx = 0;               // px; 0 = 1000 * width / 1280 (the sim cell's field of view)
  double angleRangeDeg = 60;        // part rotation drawn uniformly in [-range, range], <= 180
  int partsPerImage = 1;            // [1, 16]: parts per non-empty image (fewer if they do not fit)
  double emptyRatio = 0;            // [0, 1]: share of images without a part
  int clutter = 0;                  // [0, 64]: distractor shapes per image
  double noiseSigma = 0;            // gray levels, Gaussian
  double blurSigma = 0;             // px, Gaussian blur of the optics, 0 = none
  double illumRatio = 1;            // >= 1: brightest : darkest corner of a linear lighting gradient
  std::uint8_t background = 30;     // conveyor gray level
  int marginPx = 8;                 // every part stays this far inside the image
  std::uint64_t seed = 1;
  // Same-texture decoys (the harder set, docs/datasets.md): [0, 16] pieces cut from the
  // part's own top faces (same machining grain, same marks), 0.2-0.4 part radii across,
  // lying flat on the belt at random poses, never on a part. Not parts: not in the truth.
  int decoys = 0;
  // Commissioning (cell.yaml sim.camera_shift / sim.fiducial): the camera as rendered sits
  // shifted from the nominal one above (parts are still placed by the nominal camera, so
  // a part lies where it would, and the shifted camera sees it elsewhere); a fiducial
  // (diameter > 0) is a bright disk on the plane at a fixed base-frame position.
  double shiftXMm = 0, shiftYMm = 0, shiftZMm = 0, shiftRzDeg = 0;
  double fiducialXMm = 0, fiducialYMm = 0, fiducialDiameterMm = 0;
  std::uint8_t fiducialGray = 230;
  // Texture-less parts (`vgr sim render --plain`): every top face one uniform gray, without
  // the machining grain and without printed or engraved marks; through holes, walls, image
  // noise, blur, lighting and clutter stay. Plain machined parts: nothing for keypoint
  // detectors but the outline's corners (issue 18, "methods that must not give up").
  bool plainFaces = false;
};

// A part's pose on the conveyor and its truth in the image.
struct PlacedPart {
  double xMm = 0, yMm = 0, rzDeg = 0;  // part origin on the plane (base frame), rotation about z
  double uPx = 0, vPx = 0;             // grasp point in the image, px
  double angleDeg = 0;                 // rotation from the template, CCW as displayed, (-180, 180]
  int classIndex = 0;                  // which of the renderer's part classes (0 = the first)
};

struct PartScene {
  std::uint64_t index = 0;
  std::vector<PlacedPart> parts;  // empty = an image without a part
};

// The template the dataset's jobs are taught on: the part alone, under the optical axis,
// rz = 0, no noise, cropped to the part plus a margin.
struct PartTemplate {
  double graspU = 0, graspV = 0;  // grasp point, template px
  int offsetX = 0, offsetY = 0;   // crop origin in the full image, px
  // Top faces in template px, one polygon per layer, with the layer's height.
  struct Region {
    std::vector<vision::PixelPoint> polygon;
    double heightMm = 0;
  };
  std::vector<Region> regions;
};

class PartSceneRenderer {
 public:
  PartSceneRenderer(PartModel part, PartSceneOptions options);
  // Several part classes mixed in one image (each part's class drawn uniformly, from an RNG
  // of its own: with one class the scenes are exactly those of the constructor above). The
  // template is the first class's. classes must not be empty.
  PartSceneRenderer(std::vector<PartModel> classes, PartSceneOptions options);

  // The textured scenes of a cell config's simulated camera (`sim.scene: part | multi`):
  // the config's `model` is the true camera (fx = fy assumed; heights and z are
  // then above plane_z_mm), `sim`
  // the rest (size, noise, seed, levels, angle range, parts per image, clutter, classes).
  // Throws std::invalid_argument for an unknown name in sim.classes.
  static PartSceneRenderer fromCellConfig(const config::CellConfig& cell);

  // Draws scene `index` (poses; deterministic in seed and index).
  PartScene sample(std::uint64_t index) const;
  // Renders a scene into dst (CV_8UC1, width x height); the sensor noise is drawn from
  // `noiseIndex` (default: the scene's index; another index shows the same scene with
  // other noise, sim.still).
  void render(const PartScene& scene, cv::Mat& dst) const { render(scene, dst, scene.index); }
  void render(const PartScene& scene, cv::Mat& dst, std::uint64_t noiseIndex) const;
  // Renders the template into dst (CV_8UC1, cropped).
  PartTemplate renderTemplate(cv::Mat& dst) const;
  // Truth of a part of class classIndex placed at (xMm, yMm, rzDeg).
  PlacedPart place(double xMm, double yMm, double rzDeg, int classIndex = 0) const;

  const vision::PinholePlaneModel& camera() const { return camera_; }
  const PartModel& part() const { return part_; }
  // Every class, the first being part().
  std::vector<const PartModel*> classes() const;
  const PartSceneOptions& options() const { return options_; }
  double focalPx() const { return focal_; }

 private:
  struct Sheet;  // a layer's top face as a texture in part coordinates
  void drawPart(const PlacedPart& p, cv::Mat& dst) const;
  // PartSceneOptions::decoys pieces of the part's faces, clear of the scene's parts.
  void drawDecoys(const PartScene& scene, cv::Mat& dst) const;

  using Sheets = std::vector<std::shared_ptr<const Sheet>>;
  Sheets makeSheets(const PartModel& part) const;
  const PartModel& model(int classIndex) const;
  const Sheets& sheetsOf(int classIndex) const;

  PartModel part_;
  std::vector<std::pair<PartModel, Sheets>> extra_;  // classes 1..n-1
  PartSceneOptions options_;
  double focal_;
  vision::PinholePlaneModel camera_;     // the camera as rendered (shifted)
  vision::PinholePlaneModel placement_;  // the nominal camera parts are placed by
  std::vector<std::shared_ptr<const Sheet>> sheets_;  // one per layer
};

}  // namespace vgr::sim
