#include "config/depth_dataset_file.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/format.h>
#include <yaml-cpp/yaml.h>

#include "config/yaml_section.hpp"

namespace vgr::config {

namespace fs = std::filesystem;

Result<DepthCameraFile> loadDepthCameraFile(const std::string& path) {
  return readYamlFile<DepthCameraFile>(path, [&](const YAML::Node& root) {
    Section top(path, root, "");
    if (!root || !root.IsMap()) top.fail(root, "", "expected a mapping with width, height, fx, fy, cx, cy, depth_scale_mm");
    for (const char* k : {"width", "height", "fx", "fy", "cx", "cy", "depth_scale_mm"}) top.require(k);
    DepthCameraFile c;
    c.width = top.integer("width", 0, 1, 65535);
    c.height = top.integer("height", 0, 1, 65535);
    c.intrinsics.fx = top.number("fx", 0, 1e-6, 1e7);
    c.intrinsics.fy = top.number("fy", 0, 1e-6, 1e7);
    c.intrinsics.cx = top.number("cx", 0, 0, c.width - 1e-9);
    c.intrinsics.cy = top.number("cy", 0, 0, c.height - 1e-9);
    c.depthScaleMm = top.number("depth_scale_mm", 0, 1e-9, 100);
    // Further keys belong to whoever wrote the set (a renderer's noise model, ...): not ours.
    return c;
  });
}

Result<void> writeDepthCameraFile(const std::string& path, const DepthCameraFile& c) {
  YAML::Emitter e;
  e << YAML::BeginMap << YAML::Key << "width" << YAML::Value << c.width << YAML::Key << "height" << YAML::Value
    << c.height;
  e << YAML::Key << "fx" << YAML::Value << fmt::format("{:.6f}", c.intrinsics.fx) << YAML::Key << "fy" << YAML::Value
    << fmt::format("{:.6f}", c.intrinsics.fy) << YAML::Key << "cx" << YAML::Value << fmt::format("{:.6f}", c.intrinsics.cx)
    << YAML::Key << "cy" << YAML::Value << fmt::format("{:.6f}", c.intrinsics.cy);
  e << YAML::Key << "depth_scale_mm" << YAML::Value << fmt::format("{:.9g}", c.depthScaleMm) << YAML::EndMap;
  return writeTextFile(path, std::string(e.c_str()) + "\n");
}

namespace {

std::vector<std::string> splitCsv(const std::string& line) {
  std::vector<std::string> out;
  std::string field;
  std::istringstream in(line);
  while (std::getline(in, field, ',')) out.push_back(field);
  if (!line.empty() && line.back() == ',') out.emplace_back();
  return out;
}

std::string trimmed(std::string s) {
  while (!s.empty() && (s.back() == '\r' || s.back() == ' ' || s.back() == '\t')) s.pop_back();
  std::size_t a = 0;
  while (a < s.size() && (s[a] == ' ' || s[a] == '\t')) ++a;
  return s.substr(a);
}

}  // namespace

Result<std::vector<DepthTruthRow>> loadDepthTruthCsv(const std::string& path) {
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open");
  static const char* kColumns[] = {"image", "x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz"};
  std::string line;
  if (!std::getline(in, line)) return fail(Status::BadArgument, path + ":1: empty file (expected the header image,x_mm,...,qz)");
  const auto header = splitCsv(trimmed(line));
  for (std::size_t i = 0; i < 8; ++i)
    if (header.size() <= i || trimmed(header[i]) != kColumns[i])
      return fail(Status::BadArgument, fmt::format("{}:1: column {} must be '{}' (header image,x_mm,y_mm,z_mm,qw,qx,qy,qz[,...])",
                                                   path, i + 1, kColumns[i]));
  std::vector<DepthTruthRow> rows;
  for (int lineNo = 2; std::getline(in, line); ++lineNo) {
    line = trimmed(line);
    if (line.empty()) continue;
    auto f = splitCsv(line);
    if (f.size() != header.size())
      return fail(Status::BadArgument, fmt::format("{}:{}: {} fields, the header has {}", path, lineNo, f.size(), header.size()));
    DepthTruthRow r;
    r.line = lineNo;
    r.image = trimmed(f[0]);
    if (r.image.empty()) return fail(Status::BadArgument, fmt::format("{}:{}: column 'image' is empty", path, lineNo));
    bool anyEmpty = false, allEmpty = true;
    double v[7] = {};
    for (std::size_t i = 1; i < 8; ++i) {
      const std::string t = trimmed(f[i]);
      if (t.empty()) {
        anyEmpty = true;
        continue;
      }
      allEmpty = false;
      const auto [ptr, ec] = std::from_chars(t.data(), t.data() + t.size(), v[i - 1]);
      if (ec != std::errc{} || ptr != t.data() + t.size() || !std::isfinite(v[i - 1]))
        return fail(Status::BadArgument, fmt::format("{}:{}: column '{}': not a number: '{}'", path, lineNo, kColumns[i], t));
    }
    if (anyEmpty && !allEmpty)
      return fail(Status::BadArgument, fmt::format("{}:{}: some pose fields are empty: all seven, or none", path, lineNo));
    if (!allEmpty) {
      const double n = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
      if (std::abs(n - 1.0) > 1e-3)
        return fail(Status::BadArgument, fmt::format("{}:{}: quaternion norm {:.6f}, expected 1", path, lineNo, n));
      if (v[3] < 0) return fail(Status::BadArgument, fmt::format("{}:{}: column 'qw' is negative (the format keeps qw >= 0)", path, lineNo));
      r.modelInCamera = poseFromQuaternion(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
    }
    rows.push_back(std::move(r));
  }
  return rows;
}

Result<void> writeDepthTruthCsv(const std::string& path, const std::vector<DepthTruthRow>& rows) {
  std::string text = "image,x_mm,y_mm,z_mm,qw,qx,qy,qz\n";
  for (const auto& r : rows) {
    if (!r.modelInCamera) {
      text += r.image + ",,,,,,,\n";
      continue;
    }
    const Pose& p = *r.modelInCamera;  // core/pose keeps qw >= 0
    text += fmt::format("{},{:.4f},{:.4f},{:.4f},{:.9f},{:.9f},{:.9f},{:.9f}\n", r.image, p.x, p.y, p.z, p.qw, p.qx, p.qy, p.qz);
  }
  return writeTextFile(path, text);
}

Result<std::vector<std::string>> listDepthImages(const std::string& dir) {
  std::error_code ec;
  const fs::path images = fs::path(dir) / "images";
  if (!fs::is_directory(images, ec)) return fail(Status::BadArgument, images.string() + ": no such folder (a 3D data set keeps its depth images there)");
  std::vector<std::string> out;
  for (const auto& e : fs::directory_iterator(images, ec))
    if (e.is_regular_file() && e.path().extension() == ".png") out.push_back("images/" + e.path().filename().string());
  if (ec) return fail(Status::BadArgument, images.string() + ": " + ec.message());
  std::sort(out.begin(), out.end());
  if (out.empty()) return fail(Status::BadArgument, images.string() + ": no .png depth images");
  return out;
}

}  // namespace vgr::config
