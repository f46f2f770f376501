#include "sim/dataset.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/dataset_file.hpp"
#include "config/job.hpp"

namespace vgr::sim {

Result<PartSceneRenderer> datasetRenderer(const DatasetOptions& o) {
  if (o.classes.empty()) return PartSceneRenderer(o.part == "flat" ? PartModel::flat() : PartModel::multi(o.levels), o.scene);
  std::vector<PartModel> models;
  for (const auto& name : o.classes) {
    auto m = PartModel::byName(name);
    if (!m) return fail(Status::BadArgument, "--classes: " + m.error().message);
    if (std::any_of(models.begin(), models.end(), [&](const PartModel& x) { return x.name == name; }))
      return fail(Status::BadArgument, "--classes: '" + name + "' is listed twice");
    models.push_back(std::move(*m));
  }
  return PartSceneRenderer(std::move(models), o.scene);
}

Result<PartTemplate> writePartTemplate(const PartSceneRenderer& renderer, const std::string& dirName) {
  const std::filesystem::path dir(dirName);
  cv::Mat templ;
  const PartTemplate t = renderer.renderTemplate(templ);
  if (!cv::imwrite((dir / "template.png").string(), templ)) return fail(Status::Internal, fmt::format("{}/template.png: cannot write", dirName));
  const double graspHeightMm = renderer.part().graspHeightMm;
  config::PartTemplateFile f;
  f.grasp = {t.graspU, t.graspV};
  f.graspHeightMm = graspHeightMm;
  f.cropOffsetX = t.offsetX;
  f.cropOffsetY = t.offsetY;
  // Height factor 1 at the grasp point's height, 0.1 elsewhere (paper 000, eq. 4).
  for (const auto& r : t.regions)
    f.regions.push_back({r.polygon, r.heightMm, std::abs(r.heightMm - graspHeightMm) < 1e-6 ? 1.0 : 0.1});
  if (auto w = config::writePartTemplateFile((dir / "template.yaml").string(), f); !w) return std::unexpected(w.error());
  return t;
}

Result<DatasetSummary> writeDataset(const DatasetOptions& o) {
  namespace fs = std::filesystem;
  if (o.part != "flat" && o.part != "multi") return fail(Status::BadArgument, fmt::format("--part: expected flat or multi, got '{}'", o.part));
  if (o.levels < 2 || o.levels > 4) return fail(Status::BadArgument, fmt::format("--levels: expected 2..4, got {}", o.levels));
  std::error_code ec;
  fs::create_directories(o.outDir, ec);
  if (ec) return fail(Status::BadArgument, fmt::format("{}: cannot create the folder: {}", o.outDir, ec.message()));
  const fs::path dir(o.outDir);
  auto made = datasetRenderer(o);
  if (!made) return std::unexpected(made.error());
  const PartSceneRenderer& renderer = *made;
  const PartSceneOptions& s = renderer.options();

  if (auto t = writePartTemplate(renderer, o.outDir); !t) return std::unexpected(t.error());

  config::DatasetFile df{.part = o.part,
                               .levels = o.part == "flat" ? 1 : o.levels,
                               .count = o.count,
                               .seed = s.seed,
                               .width = s.width,
                               .height = s.height,
                               .angleRangeDeg = s.angleRangeDeg,
                               .partsPerImage = s.partsPerImage,
                               .emptyRatio = s.emptyRatio,
                               .clutter = s.clutter,
                               .noiseSigma = s.noiseSigma,
                               .blurSigma = s.blurSigma,
                               .illumRatio = s.illumRatio,
                               .decoys = s.decoys,
                               .plain = s.plainFaces,
                               .fx = renderer.focalPx(),
                               .fy = renderer.focalPx(),
                               .cx = (s.width - 1) / 2.0,
                               .cy = (s.height - 1) / 2.0,
                               .cameraHeightMm = s.cameraHeightMm,
                               .classes = o.classes};
  if (auto w = config::writeDatasetFile((dir / "dataset.yaml").string(), df); !w) return std::unexpected(w.error());

  std::ofstream csv(dir / "truth.csv");
  const bool labelled = !o.classes.empty();
  csv << (labelled ? "image,x_px,y_px,angle_deg,part,x_mm,y_mm,rz_deg,label\n" : "image,x_px,y_px,angle_deg,part,x_mm,y_mm,rz_deg\n");
  DatasetSummary sum;
  cv::Mat img;
  for (int i = 0; i < o.count; ++i) {
    const PartScene scene = renderer.sample(static_cast<std::uint64_t>(i));
    renderer.render(scene, img);
    const std::string name = fmt::format("img_{:05d}.png", i);
    if (!cv::imwrite((dir / name).string(), img)) return fail(Status::Internal, fmt::format("{}/{}: cannot write", o.outDir, name));
    if (scene.parts.empty()) {
      csv << name << (labelled ? ",,,,-1,,,,\n" : ",,,,-1,,,\n");  // an image without a part: one row, empty truth
      ++sum.emptyImages;
    }
    for (std::size_t k = 0; k < scene.parts.size(); ++k) {
      const auto& p = scene.parts[k];
      csv << fmt::format("{},{:.4f},{:.4f},{:.4f},{},{:.4f},{:.4f},{:.4f}", name, p.uPx, p.vPx, p.angleDeg, k, p.xMm, p.yMm, p.rzDeg);
      csv << (labelled ? "," + o.classes.at(static_cast<std::size_t>(p.classIndex)) + "\n" : std::string("\n"));
      ++sum.parts;
    }
    ++sum.images;
  }
  csv.close();
  if (!csv) return fail(Status::Internal, fmt::format("{}/truth.csv: cannot write", o.outDir));
  return sum;
}

}  // namespace vgr::sim
