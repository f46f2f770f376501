#include "sim/dataset.hpp"

#include <filesystem>
#include <fstream>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

namespace vgr::sim {

PartSceneRenderer datasetRenderer(const DatasetOptions& o) {
  return PartSceneRenderer(o.part == "flat" ? PartModel::flat() : PartModel::multi(o.levels), o.scene);
}

namespace {

Result<void> writeText(const std::filesystem::path& path, const std::string& text) {
  std::ofstream out(path);
  out << text;
  out.close();
  if (!out) return fail(Status::Internal, fmt::format("{}: cannot write", path.string()));
  return {};
}

}  // namespace

Result<PartTemplate> writePartTemplate(const PartSceneRenderer& renderer, const std::string& dirName) {
  const std::filesystem::path dir(dirName);
  cv::Mat templ;
  const PartTemplate t = renderer.renderTemplate(templ);
  if (!cv::imwrite((dir / "template.png").string(), templ)) return fail(Status::Internal, fmt::format("{}/template.png: cannot write", dirName));
  std::string ty = fmt::format(
      "# Template of the rendered part (vgr sim render, vgr demo): alone under the optical axis, rz = 0.\n"
      "# Teach a job on it: vgr teach --image template.png --grasp {:.3f},{:.3f} --regions template.yaml --out JOB\n"
      "image: template.png\n"
      "grasp: {{x_px: {:.4f}, y_px: {:.4f}}}   # template px, pixel centres at integers, y down\n"
      "grasp_height_mm: {:.3f}\n"
      "crop_offset: {{x_px: {}, y_px: {}}}     # template px + offset = px of the full image\n"
      "# Top faces of the part's levels in template px (paper 000's contour regions); height_factor\n"
      "# 1 at the grasp point's height, 0.1 elsewhere (paper 000, eq. 4: far less than 1).\n"
      "regions:\n",
      t.graspU, t.graspV, t.graspU, t.graspV, renderer.part().graspHeightMm, t.offsetX, t.offsetY);
  for (const auto& r : t.regions) {
    ty += fmt::format("  - height_mm: {:.3f}\n    height_factor: {}\n    polygon: [", r.heightMm,
                      std::abs(r.heightMm - renderer.part().graspHeightMm) < 1e-6 ? "1.0" : "0.1");
    for (std::size_t i = 0; i < r.polygon.size(); ++i)
      ty += fmt::format("{}[{:.2f}, {:.2f}]", i ? ", " : "", r.polygon[i].u, r.polygon[i].v);
    ty += "]\n";
  }
  if (auto w = writeText(dir / "template.yaml", ty); !w) return std::unexpected(w.error());
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
  const PartSceneRenderer renderer = datasetRenderer(o);
  const PartSceneOptions& s = renderer.options();

  if (auto t = writePartTemplate(renderer, o.outDir); !t) return std::unexpected(t.error());

  const std::string ds = fmt::format(
      "# How this dataset was made (vgr sim render); truth is in truth.csv.\n"
      "part: {}\nlevels: {}\ncount: {}\nseed: {}\nwidth: {}\nheight: {}\n"
      "angle_range_deg: {}\nparts_per_image: {}\nempty_ratio: {}\nclutter: {}\nnoise_sigma: {}\n"
      "blur_sigma: {}\nillum_ratio: {}\ndecoys: {}\n"
      "# Pinhole camera looking straight down; base frame origin on the plane under the optical centre.\n"
      "camera: {{fx: {:.4f}, fy: {:.4f}, cx: {:.2f}, cy: {:.2f}, height_mm: {}}}\n",
      o.part, o.part == "flat" ? 1 : o.levels, o.count, s.seed, s.width, s.height, s.angleRangeDeg, s.partsPerImage,
      s.emptyRatio, s.clutter, s.noiseSigma, s.blurSigma, s.illumRatio, s.decoys, renderer.focalPx(), renderer.focalPx(),
      (s.width - 1) / 2.0, (s.height - 1) / 2.0, s.cameraHeightMm);
  if (auto w = writeText(dir / "dataset.yaml", ds); !w) return std::unexpected(w.error());

  std::ofstream csv(dir / "truth.csv");
  csv << "image,x_px,y_px,angle_deg,part,x_mm,y_mm,rz_deg\n";
  DatasetSummary sum;
  cv::Mat img;
  for (int i = 0; i < o.count; ++i) {
    const PartScene scene = renderer.sample(static_cast<std::uint64_t>(i));
    renderer.render(scene, img);
    const std::string name = fmt::format("img_{:05d}.png", i);
    if (!cv::imwrite((dir / name).string(), img)) return fail(Status::Internal, fmt::format("{}/{}: cannot write", o.outDir, name));
    if (scene.parts.empty()) {
      csv << name << ",,,,-1,,,\n";  // an image without a part: one row, empty truth
      ++sum.emptyImages;
    }
    for (std::size_t k = 0; k < scene.parts.size(); ++k) {
      const auto& p = scene.parts[k];
      csv << fmt::format("{},{:.4f},{:.4f},{:.4f},{},{:.4f},{:.4f},{:.4f}\n", name, p.uPx, p.vPx, p.angleDeg, k, p.xMm, p.yMm, p.rzDeg);
      ++sum.parts;
    }
    ++sum.images;
  }
  csv.close();
  if (!csv) return fail(Status::Internal, fmt::format("{}/truth.csv: cannot write", o.outDir));
  return sum;
}

}  // namespace vgr::sim
