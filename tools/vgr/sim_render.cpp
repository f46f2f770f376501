#include "tools/vgr/sim_render.hpp"

#include <cstdio>

#include <CLI/CLI.hpp>

namespace vgr::tools {

int runSimRender(const sim::DatasetOptions& o) {
  auto r = sim::writeDataset(o);
  if (!r) return badInput(r.error().message);
  std::printf("{\"out\":\"%s\",\"images\":%d,\"empty_images\":%d,\"parts\":%d}\n", o.outDir.c_str(), r->images, r->emptyImages,
              r->parts);
  return 0;
}

CLI::App* SimRenderCommand::add(CLI::App& parent) {
  auto& d = options_;
  auto* renderCmd = parent.add_subcommand("render", "write a localization dataset with ground truth (docs/datasets.md)");
  renderCmd->add_option("--out", d.outDir, "output folder")->required();
  renderCmd->add_option("--count", d.count, "images")->check(CLI::Range(1, 1000000));
  renderCmd->add_option("--seed", d.scene.seed, "scene seed");
  renderCmd->add_option("--part", d.part, "flat or multi")->check(CLI::IsMember({"flat", "multi"}));
  renderCmd->add_option("--classes", d.classes,
                        "part classes mixed in every image, comma-separated (flat, disc, ring, hex, square, square_small, "
                        "rect, rect_notch); truth.csv gains a label column (docs/datasets.md)")
      ->delimiter(',');
  renderCmd->add_option("--levels", d.levels, "height levels of the multi part")->check(CLI::Range(2, 4));
  renderCmd->add_option("--angle-range", d.scene.angleRangeDeg, "rotation drawn in [-DEG, DEG] (180 = full turn)")->check(CLI::Range(0.0, 180.0));
  renderCmd->add_option("--noise", d.scene.noiseSigma, "Gaussian noise sigma, gray levels")->check(CLI::Range(0.0, 64.0));
  renderCmd->add_option("--blur", d.scene.blurSigma, "Gaussian blur sigma, px")->check(CLI::Range(0.0, 10.0));
  renderCmd->add_option("--illum-ratio", d.scene.illumRatio, "lighting gradient, brightest : darkest (1 = even)")->check(CLI::Range(1.0, 10.0));
  renderCmd->add_option("--clutter", d.scene.clutter, "distractor shapes per image")->check(CLI::Range(0, 64));
  renderCmd->add_option("--decoys", d.scene.decoys, "pieces of the part's own faces lying on the belt, per image")->check(CLI::Range(0, 16));
  renderCmd->add_flag("--plain", d.scene.plainFaces,
                      "texture-less parts: uniform top faces, no grain, no printed marks (holes, walls, noise, clutter stay)");
  renderCmd->add_option("--parts", d.scene.partsPerImage, "parts per non-empty image")->check(CLI::Range(1, 16));
  renderCmd->add_option("--empty-ratio", d.scene.emptyRatio, "share of images without a part")->check(CLI::Range(0.0, 1.0));
  renderCmd->add_option("--width", d.scene.width, "image width, px")->check(CLI::Range(64, 2448));
  renderCmd->add_option("--height", d.scene.height, "image height, px")->check(CLI::Range(64, 2048));
  renderCmd->add_option("--camera-height", d.scene.cameraHeightMm, "camera above the conveyor, mm")->check(CLI::Range(100.0, 5000.0));
  renderCmd->add_option("--focal", d.scene.focalPx, "focal length, px (0 = 1000 * width / 1280)")->check(CLI::Range(0.0, 100000.0));
  return renderCmd;
}

}  // namespace vgr::tools
