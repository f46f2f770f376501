#include "tools/vgr/sim_render.hpp"

#include <cstdio>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "sim/depth_parts.hpp"


namespace vgr::tools {
namespace {

int render2d(const SimRenderOptions& o) {
  sim::DatasetOptions d = o.flat;
  d.outDir = o.out;
  if (!o.part.empty()) {
    if (o.part != "flat" && o.part != "multi") return badInput(fmt::format("--part: expected flat or multi (2D), got '{}'", o.part));
    d.part = o.part;
  }
  if (o.count) d.count = *o.count;
  if (o.seed) d.scene.seed = *o.seed;
  if (o.clutter) d.scene.clutter = *o.clutter;
  if (o.parts) d.scene.partsPerImage = *o.parts;
  if (o.width) d.scene.width = *o.width;
  if (o.height) d.scene.height = *o.height;
  if (o.noise) d.scene.noiseSigma = *o.noise;
  if (o.emptyRatio) d.scene.emptyRatio = *o.emptyRatio;
  if (o.focal) d.scene.focalPx = *o.focal;
  if (d.scene.partsPerImage < 1) return badInput("--parts: expected 1..16 in 2D");
  if (d.scene.noiseSigma > 64) return badInput("--noise: expected [0, 64] gray levels in 2D");
  if (d.scene.width < 64 || d.scene.width > 2448 || d.scene.height < 64 || d.scene.height > 2048)
    return badInput("--width/--height: expected 64..2448 x 64..2048 in 2D");
  auto r = sim::writeDataset(d);
  if (!r) return badInput(r.error().message);
  std::printf("{\"out\":\"%s\",\"images\":%d,\"empty_images\":%d,\"parts\":%d}\n", d.outDir.c_str(), r->images, r->emptyImages, r->parts);
  return 0;
}

int render3d(const SimRenderOptions& o) {
  sim::DepthDatasetOptions d = o.depth;
  d.outDir = o.out;
  if (!o.part.empty()) d.scene.part = o.part;
  if (auto p = sim::depthPart(d.scene.part); !p) return badInput("--part: " + p.error().message);
  if (o.count) d.count = *o.count;
  if (o.seed) d.scene.seed = *o.seed;
  if (o.clutter) d.scene.clutter = *o.clutter;
  if (o.parts) d.scene.partsPerScene = *o.parts;
  if (o.noise) d.scene.sensor.noiseMmAt500 = *o.noise;
  if (o.emptyRatio) d.scene.emptyRatio = *o.emptyRatio;
  auto& cam = d.scene.camera;
  if (o.width || o.height) {  // keep the field of view: focal and principal point scale with the width
    const int w = o.width.value_or(cam.width), h = o.height.value_or(cam.height);
    cam.fx = cam.fy = 800.0 * w / 640.0;
    cam.width = w, cam.height = h;
    cam.cx = (w - 1) / 2.0, cam.cy = (h - 1) / 2.0;
  }
  if (o.focal) cam.fx = cam.fy = *o.focal;
  auto r = sim::writeDepthDataset(d);
  if (!r) return badInput(r.error().message);
  std::printf("{\"out\":\"%s\",\"images\":%d,\"empty_images\":%d,\"parts\":%d,\"views\":%d}\n", d.outDir.c_str(), r->images,
              r->emptyImages, r->parts, r->views);
  return 0;
}

}  // namespace

int runSimRender(const SimRenderOptions& o) {
  if (!o.wrongMode.empty()) {
    std::string list;
    for (const auto& n : o.wrongMode) list += (list.empty() ? "" : ", ") + n;
    return badInput(fmt::format("{}: not an option of {} data sets", list, o.threeD ? "3D (--3d)" : "2D (add --3d for 3D)"));
  }
  return o.threeD ? render3d(o) : render2d(o);
}

int SimRenderCommand::run() {
  auto& o = options_;
  for (const auto* opt : o.threeD ? only2d_ : only3d_)
    if (opt->count() > 0) o.wrongMode.push_back(opt->get_name());
  return runSimRender(o);
}

CLI::App* SimRenderCommand::add(CLI::App& parent) {
  auto& o = options_;
  auto& d = o.flat;
  auto& z = o.depth;
  auto* c = parent.add_subcommand("render", "write a data set with ground truth: 2D (docs/datasets.md) or --3d (docs/3d.md)");
  c->add_flag("--3d", o.threeD, "a 3D data set of depth images in the fixed format (docs/3d.md)");
  c->add_option("--out", o.out, "output folder")->required();
  c->add_option("--count", o.count, "images (default 100)")->check(CLI::Range(1, 1000000));
  c->add_option("--seed", o.seed, "scene seed (default 1)");
  c->add_option("--part", o.part, "2D: flat or multi (default multi); 3D: bracket, housing or lever (default bracket)");
  c->add_option("--clutter", o.clutter, "2D: distractor shapes per image (default 0); 3D: distractor objects in the bin (default 6)")
      ->check(CLI::Range(0, 64));
  c->add_option("--parts", o.parts, "parts per non-empty image (2D 1..16, 3D 0..8; default 1)")->check(CLI::Range(0, 16));
  c->add_option("--empty-ratio", o.emptyRatio, "share of images without a part (default 0)")->check(CLI::Range(0.0, 1.0));
  c->add_option("--width", o.width, "image width, px (2D default 1280; 3D default 640, focal scaled with it)")->check(CLI::Range(16, 8192));
  c->add_option("--height", o.height, "image height, px (2D default 1024; 3D default 480)")->check(CLI::Range(16, 8192));
  c->add_option("--noise", o.noise, "2D: Gaussian noise, gray levels (default 0); 3D: sigma of z at 500 mm, mm (default 0.3), grows with z^2")
      ->check(CLI::Range(0.0, 64.0));
  c->add_option("--focal", o.focal, "focal length, px (2D: 0 = 1000 * width / 1280; 3D default 800 * width / 640)")
      ->check(CLI::Range(0.0, 100000.0));
  // 2D only.
  only2d_.push_back(c->add_option("--classes", d.classes,
                                  "2D: part classes mixed in every image, comma-separated (flat, disc, ring, hex, square, square_small, "
                                  "rect, rect_notch); truth.csv gains a label column (docs/datasets.md)")
                        ->delimiter(','));
  only2d_.push_back(c->add_option("--levels", d.levels, "2D: height levels of the multi part")->check(CLI::Range(2, 4)));
  only2d_.push_back(c->add_option("--angle-range", d.scene.angleRangeDeg, "2D: rotation drawn in [-DEG, DEG] (180 = full turn)")
                        ->check(CLI::Range(0.0, 180.0)));
  only2d_.push_back(c->add_option("--blur", d.scene.blurSigma, "2D: Gaussian blur sigma, px")->check(CLI::Range(0.0, 10.0)));
  only2d_.push_back(c->add_option("--illum-ratio", d.scene.illumRatio, "2D: lighting gradient, brightest : darkest (1 = even)")
                        ->check(CLI::Range(1.0, 10.0)));
  only2d_.push_back(c->add_option("--decoys", d.scene.decoys, "2D: pieces of the part's own faces lying on the belt, per image")
                        ->check(CLI::Range(0, 16)));
  only2d_.push_back(c->add_flag("--plain", d.scene.plainFaces,
                                "2D: texture-less parts: uniform top faces, no grain, no printed marks (holes, walls, noise, clutter stay)"));
  only2d_.push_back(c->add_option("--camera-height", d.scene.cameraHeightMm, "2D: camera above the conveyor, mm")
                        ->check(CLI::Range(100.0, 5000.0)));
  // 3D only.
  auto& s = z.scene;
  only3d_.push_back(c->add_option("--tilt-max", s.tiltMaxDeg, "3D: parts tilted by up to DEG (default 20)")->check(CLI::Range(0.0, 60.0)));
  only3d_.push_back(c->add_option("--dropout", s.sensor.dropout, "3D: share of pixels without data (default 0.01)")->check(CLI::Range(0.0, 0.99)));
  only3d_.push_back(c->add_option("--jump", s.sensor.jumpMm, "3D: pixels at depth jumps above MM are invalid (default 3)")->check(CLI::Range(0.01, 1000.0)));
  only3d_.push_back(c->add_option("--grazing", s.sensor.grazingDeg, "3D: surfaces seen more obliquely than DEG are invalid (default 78)")
                        ->check(CLI::Range(1.0, 90.0)));
  only3d_.push_back(c->add_option("--depth-scale", s.camera.depthScaleMm, "3D: mm per 16-bit step (default 0.1)")->check(CLI::Range(0.001, 10.0)));
  only3d_.push_back(c->add_option("--floor-distance", s.floorMm, "3D: camera to the bin floor, mm (default 560)")->check(CLI::Range(200.0, 5000.0)));
  only3d_.push_back(c->add_option("--camera-tilt-max", s.cameraTiltMaxDeg, "3D: camera tilted from straight down by up to DEG (default 5)")
                        ->check(CLI::Range(0.0, 30.0)));
  only3d_.push_back(c->add_flag("!--no-bin", s.bin, "3D: parts on a table instead of in a bin"));
  only3d_.push_back(c->add_option("--face", s.face, "3D: every part rests on this stable face (e.g. -z, its natural one; default any)"));
  only3d_.push_back(c->add_option("--occlusion", s.occlusion, "3D: a board hides this share of the first part's pixels (default 0)")
                        ->check(CLI::Range(0.0, 0.95)));
  only3d_.push_back(c->add_option("--views", z.views, "3D: model-building views of the part alone on a table (default 12, 0 = none)")
                        ->check(CLI::Range(0, 72)));
  only3d_.push_back(c->add_option("--view-distance", z.viewOptions.distanceMm, "3D: view camera to the part, mm (default 450)")
                        ->check(CLI::Range(150.0, 2000.0)));
  only3d_.push_back(c->add_option("--view-noise-mm", z.viewOptions.poseNoiseMm, "3D: reported view pose off by U(-MM, MM) per axis (default 1)")
                        ->check(CLI::Range(0.0, 100.0)));
  only3d_.push_back(c->add_option("--view-noise-deg", z.viewOptions.poseNoiseDeg,
                                  "3D: reported view pose turned by U(-DEG, DEG) about each axis (default 0.5)")
                        ->check(CLI::Range(0.0, 45.0)));
  only3d_.push_back(c->add_option("--bad-view", z.viewOptions.badView, "3D: this view's reported position is off by --bad-view-mm more (default -1: none)")
                        ->check(CLI::Range(-1, 71)));
  only3d_.push_back(c->add_option("--bad-view-mm", z.viewOptions.badViewMm, "3D: the bad view's offset, mm (default 20)")->check(CLI::Range(0.0, 1000.0)));
  only3d_.push_back(c->add_flag("--grasps", z.grasps, "3D: also write the grasp ground truth grasps.csv (docs/grasp.md)"));
  return c;
}

}  // namespace vgr::tools
