#include "sim/dataset.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <utility>

#include <fmt/core.h>
#include <yaml-cpp/yaml.h>
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
  const double graspHeightMm = renderer.part().graspHeightMm;
  YAML::Emitter y;
  y << YAML::Comment(fmt::format(
      "Template of the rendered part (vgr sim render, vgr demo): alone under the optical axis, rz = 0.\n"
      "Teach a job on it: vgr teach --image template.png --grasp {:.3f},{:.3f} --regions template.yaml --out JOB",
      t.graspU, t.graspV));
  y << YAML::BeginMap;
  y << YAML::Key << "image" << YAML::Value << "template.png";
  y << YAML::Key << "grasp" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x_px" << YAML::Value
    << fmt::format("{:.4f}", t.graspU) << YAML::Key << "y_px" << YAML::Value << fmt::format("{:.4f}", t.graspV)
    << YAML::EndMap << YAML::Comment("template px, pixel centres at integers, y down");
  y << YAML::Key << "grasp_height_mm" << YAML::Value << fmt::format("{:.3f}", graspHeightMm);
  y << YAML::Key << "crop_offset" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x_px" << YAML::Value
    << t.offsetX << YAML::Key << "y_px" << YAML::Value << t.offsetY << YAML::EndMap
    << YAML::Comment("template px + offset = px of the full image");
  y << YAML::Newline
    << YAML::Comment("Top faces of the part's levels in template px (paper 000's contour regions); height_factor\n"
                     "1 at the grasp point's height, 0.1 elsewhere (paper 000, eq. 4: far less than 1).");
  y << YAML::Key << "regions" << YAML::Value;
  if (t.regions.empty()) y << YAML::Flow;
  y << YAML::BeginSeq;
  for (const auto& r : t.regions) {
    y << YAML::BeginMap << YAML::Key << "height_mm" << YAML::Value << fmt::format("{:.3f}", r.heightMm) << YAML::Key
      << "height_factor" << YAML::Value << (std::abs(r.heightMm - graspHeightMm) < 1e-6 ? "1.0" : "0.1") << YAML::Key
      << "polygon" << YAML::Value << YAML::Flow << YAML::BeginSeq;
    for (const auto& p : r.polygon) y << YAML::BeginSeq << fmt::format("{:.2f}", p.u) << fmt::format("{:.2f}", p.v) << YAML::EndSeq;
    y << YAML::EndSeq << YAML::EndMap;
  }
  y << YAML::EndSeq << YAML::EndMap;
  const std::string ty = std::string(y.c_str()) + "\n";
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

  YAML::Emitter d;
  d << YAML::Comment("How this dataset was made (vgr sim render); truth is in truth.csv.");
  d << YAML::BeginMap;
  d << YAML::Key << "part" << YAML::Value << o.part;
  d << YAML::Key << "levels" << YAML::Value << (o.part == "flat" ? 1 : o.levels);
  d << YAML::Key << "count" << YAML::Value << o.count;
  d << YAML::Key << "seed" << YAML::Value << fmt::format("{}", s.seed);
  d << YAML::Key << "width" << YAML::Value << s.width;
  d << YAML::Key << "height" << YAML::Value << s.height;
  const std::pair<const char*, double> numbers[] = {
      {"angle_range_deg", s.angleRangeDeg}, {"parts_per_image", static_cast<double>(s.partsPerImage)},
      {"empty_ratio", s.emptyRatio},        {"clutter", static_cast<double>(s.clutter)},
      {"noise_sigma", s.noiseSigma},        {"blur_sigma", s.blurSigma},
      {"illum_ratio", s.illumRatio},        {"decoys", static_cast<double>(s.decoys)}};
  for (const auto& [key, value] : numbers) d << YAML::Key << key << YAML::Value << fmt::format("{}", value);
  d << YAML::Newline
    << YAML::Comment("Pinhole camera looking straight down; base frame origin on the plane under the optical centre.");
  d << YAML::Key << "camera" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "fx" << YAML::Value
    << fmt::format("{:.4f}", renderer.focalPx()) << YAML::Key << "fy" << YAML::Value
    << fmt::format("{:.4f}", renderer.focalPx()) << YAML::Key << "cx" << YAML::Value
    << fmt::format("{:.2f}", (s.width - 1) / 2.0) << YAML::Key << "cy" << YAML::Value
    << fmt::format("{:.2f}", (s.height - 1) / 2.0) << YAML::Key << "height_mm" << YAML::Value
    << fmt::format("{}", s.cameraHeightMm) << YAML::EndMap;
  d << YAML::EndMap;
  const std::string ds = std::string(d.c_str()) + "\n";
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
