#include "config/dataset_file.hpp"

#include <limits>

#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

#include "config/yaml_section.hpp"

namespace vgr::config {

std::string datasetYaml(const DatasetFile& d) {
  YAML::Emitter y;
  y << YAML::Comment("How this dataset was made (vgr sim render); truth is in truth.csv.");
  y << YAML::BeginMap;
  y << YAML::Key << "part" << YAML::Value << d.part;
  y << YAML::Key << "levels" << YAML::Value << d.levels;
  y << YAML::Key << "count" << YAML::Value << d.count;
  y << YAML::Key << "seed" << YAML::Value << d.seed;
  y << YAML::Key << "width" << YAML::Value << d.width;
  y << YAML::Key << "height" << YAML::Value << d.height;
  y << YAML::Key << "angle_range_deg" << YAML::Value << fmt::format("{}", d.angleRangeDeg);
  y << YAML::Key << "parts_per_image" << YAML::Value << d.partsPerImage;
  y << YAML::Key << "empty_ratio" << YAML::Value << fmt::format("{}", d.emptyRatio);
  y << YAML::Key << "clutter" << YAML::Value << d.clutter;
  y << YAML::Key << "noise_sigma" << YAML::Value << fmt::format("{}", d.noiseSigma);
  y << YAML::Key << "blur_sigma" << YAML::Value << fmt::format("{}", d.blurSigma);
  y << YAML::Key << "illum_ratio" << YAML::Value << fmt::format("{}", d.illumRatio);
  y << YAML::Key << "decoys" << YAML::Value << d.decoys;
  if (d.plain) y << YAML::Key << "plain" << YAML::Value << true;
  if (!d.classes.empty()) y << YAML::Key << "classes" << YAML::Value << YAML::Flow << d.classes;
  y << YAML::Newline
    << YAML::Comment("Pinhole camera looking straight down; base frame origin on the plane under the optical centre.");
  y << YAML::Key << "camera" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "fx" << YAML::Value
    << fmt::format("{:.4f}", d.fx) << YAML::Key << "fy" << YAML::Value << fmt::format("{:.4f}", d.fy) << YAML::Key
    << "cx" << YAML::Value << fmt::format("{:.2f}", d.cx) << YAML::Key << "cy" << YAML::Value
    << fmt::format("{:.2f}", d.cy) << YAML::Key << "height_mm" << YAML::Value << fmt::format("{}", d.cameraHeightMm)
    << YAML::EndMap;
  y << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

Result<void> writeDatasetFile(const std::string& path, const DatasetFile& d) { return writeTextFile(path, datasetYaml(d)); }

Result<DatasetFile> loadDatasetFile(const std::string& path) {
  return readYamlFile<DatasetFile>(path, [&](const YAML::Node& root) {
    Section top(path, root, "");
    if (!root || root.IsNull()) top.fail(root, "", "the file is empty");
    constexpr int kMaxInt = std::numeric_limits<int>::max();
    DatasetFile d;
    d.part = top.text("part", d.part);
    d.levels = top.integer("levels", d.levels, 1, 16);
    d.count = top.integer("count", d.count, 0, kMaxInt);
    top.read<std::uint64_t>("seed", d.seed);
    d.width = top.integer("width", d.width, 1, 65535);
    d.height = top.integer("height", d.height, 1, 65535);
    d.angleRangeDeg = top.number("angle_range_deg", d.angleRangeDeg, 0, 180);
    d.partsPerImage = top.integer("parts_per_image", d.partsPerImage, 0, 1024);
    d.emptyRatio = top.number("empty_ratio", d.emptyRatio, 0, 1);
    d.clutter = top.integer("clutter", d.clutter, 0, 1024);
    d.noiseSigma = top.number("noise_sigma", d.noiseSigma, 0, 255);
    d.blurSigma = top.number("blur_sigma", d.blurSigma, 0, 1000);
    d.illumRatio = top.number("illum_ratio", d.illumRatio, 0, 1e6);
    d.decoys = top.integer("decoys", d.decoys, 0, 1024);
    top.read<bool>("plain", d.plain);
    if (const YAML::Node c = top.get("classes"); c && !c.IsNull()) {
      if (!c.IsSequence()) top.fail(c, "classes", "expected a list of class names");
      for (std::size_t i = 0; i < c.size(); ++i) {
        if (!c[i].IsScalar() || c[i].Scalar().empty()) top.fail(c[i], "classes", "expected a class name");
        d.classes.push_back(c[i].Scalar());
      }
    }
    Section cam(path, top.get("camera"), "camera");
    cam.require("fx");
    d.fx = cam.number("fx", 0, 1e-9, 1e9);
    d.fy = cam.number("fy", d.fx, 1e-9, 1e9);
    d.cx = cam.number("cx", 0, -1e6, 1e6);
    d.cy = cam.number("cy", 0, -1e6, 1e6);
    d.cameraHeightMm = cam.number("height_mm", 0, 1e-9, 1e7);
    cam.finish();
    top.finish();
    return d;
  });
}

}  // namespace vgr::config
