#include "config/depth_dataset.hpp"

#include "config/csv_line.hpp"

#include <algorithm>
#include <charconv>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>

#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

#include "config/yaml_section.hpp"

namespace vgr::config {
namespace {


bool parseDouble(const std::string& s, double& v) {
  const auto r = std::from_chars(s.data(), s.data() + s.size(), v);
  return !s.empty() && r.ec == std::errc() && r.ptr == s.data() + s.size() && std::isfinite(v);
}

const std::vector<std::string> kPoseColumns{"x_mm", "y_mm", "z_mm", "qw", "qx", "qy", "qz"};

// Reads the 7 pose fields starting at f[at]; names the column on error.
Result<Pose> parsePose(const std::vector<std::string>& f, std::size_t at, const std::string& where, const std::string& prefix) {
  double v[7];
  for (std::size_t k = 0; k < 7; ++k)
    if (!parseDouble(f[at + k], v[k]))
      return fail(Status::BadArgument, fmt::format("{}: column '{}{}': expected a number, got '{}'", where, prefix, kPoseColumns[k], f[at + k]));
  const double n = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
  if (std::abs(n - 1) > 1e-3)
    return fail(Status::BadArgument, fmt::format("{}: the quaternion ({}, {}, {}, {}) is not unit length (|q| = {:.6f})", where, v[3], v[4], v[5], v[6], n));
  const double s = v[3] < 0 ? -1 / n : 1 / n;  // the same rotation with qw >= 0
  return Pose{v[0], v[1], v[2], v[3] * s, v[4] * s, v[5] * s, v[6] * s};
}

Result<std::vector<std::vector<std::string>>> readCsv(const std::string& path, const std::vector<std::string>& fixed,
                                                      std::vector<int>& lines) {
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open");
  std::string line;
  std::string want;
  for (const auto& c : fixed) want += (want.empty() ? "" : ",") + c;
  if (!std::getline(in, line)) return fail(Status::BadArgument, fmt::format("{}:1: empty file, expected the header {}", path, want));
  const auto header = splitCsvLine(line);
  for (std::size_t i = 0; i < fixed.size(); ++i)
    if (i >= header.size() || header[i] != fixed[i])
      return fail(Status::BadArgument, fmt::format("{}:1: the header must start with {} (column {} is '{}')", path, want, i + 1,
                                                   i < header.size() ? header[i] : ""));
  std::vector<std::vector<std::string>> rows;
  int n = 1;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line == "\r") continue;
    auto f = splitCsvLine(line);
    if (f.size() != header.size())
      return fail(Status::BadArgument, fmt::format("{}:{}: expected {} fields as in the header, got {}", path, n, header.size(), f.size()));
    rows.push_back(std::move(f));
    lines.push_back(n);
  }
  if (rows.empty()) return fail(Status::BadArgument, path + ": no rows after the header");
  return rows;
}

std::string poseFields(const Pose& p) {
  return fmt::format("{:.4f},{:.4f},{:.4f},{:.8f},{:.8f},{:.8f},{:.8f}", p.x, p.y, p.z, p.qw, p.qx, p.qy, p.qz);
}

}  // namespace

std::string depthCameraYaml(const DepthCameraFile& c) {
  YAML::Emitter y;
  y << YAML::Comment("Depth camera of a 3D data set (docs/3d.md): pinhole intrinsics in px for this image size,\n"
                     "pixel centres at integers; a 16-bit value v is v * depth_scale_mm mm of z, 0 = no data.");
  y << YAML::BeginMap;
  y << YAML::Key << "width" << YAML::Value << c.width;
  y << YAML::Key << "height" << YAML::Value << c.height;
  y << YAML::Key << "fx" << YAML::Value << fmt::format("{}", c.fx);
  y << YAML::Key << "fy" << YAML::Value << fmt::format("{}", c.fy);
  y << YAML::Key << "cx" << YAML::Value << fmt::format("{}", c.cx);
  y << YAML::Key << "cy" << YAML::Value << fmt::format("{}", c.cy);
  y << YAML::Key << "depth_scale_mm" << YAML::Value << fmt::format("{}", c.depthScaleMm);
  y << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

Result<void> writeDepthCameraFile(const std::string& path, const DepthCameraFile& c) { return writeTextFile(path, depthCameraYaml(c)); }

Result<DepthCameraFile> loadDepthCameraFile(const std::string& path) {
  return readYamlFile<DepthCameraFile>(path, [&](const YAML::Node& root) {
    Section top(path, root, "");
    if (!root || root.IsNull() || !root.IsMap()) top.fail(root, "", "expected a mapping with width, height, fx, fy, cx, cy, depth_scale_mm");
    for (const char* k : {"width", "height", "fx", "fy", "cx", "cy", "depth_scale_mm"}) top.require(k);
    DepthCameraFile c;
    c.width = top.integer("width", 0, 1, 65535);
    c.height = top.integer("height", 0, 1, 65535);
    c.fx = top.number("fx", 0, 1e-6, 1e7);
    c.fy = top.number("fy", 0, 1e-6, 1e7);
    c.cx = top.number("cx", 0, 0, c.width - 1);
    c.cy = top.number("cy", 0, 0, c.height - 1);
    c.depthScaleMm = top.number("depth_scale_mm", 0, 1e-9, 100);
    top.finish();
    return c;
  });
}

Result<std::vector<std::string>> listDepthImages(const std::string& dir) {
  std::error_code ec;
  const std::filesystem::path images = std::filesystem::path(dir) / "images";
  if (!std::filesystem::is_directory(images, ec))
    return fail(Status::BadArgument, images.string() + ": no such folder (a 3D data set keeps its depth images there)");
  std::vector<std::string> out;
  for (const auto& e : std::filesystem::directory_iterator(images, ec))
    if (e.is_regular_file() && e.path().extension() == ".png") out.push_back("images/" + e.path().filename().string());
  if (ec) return fail(Status::BadArgument, images.string() + ": " + ec.message());
  std::sort(out.begin(), out.end());
  if (out.empty()) return fail(Status::BadArgument, images.string() + ": no .png depth images");
  return out;
}

Result<void> writeDepthTruth(const std::string& path, const std::vector<DepthTruthRow>& rows) {
  std::string text = depthTruthCsvHeader() + "\n";
  for (const auto& r : rows) text += depthTruthCsvRow(r.image, r.hasPart ? &r.pose : nullptr) + "\n";
  return writeTextFile(path, text);
}

std::string depthTruthCsvHeader() { return "image,x_mm,y_mm,z_mm,qw,qx,qy,qz"; }
std::string depthTruthCsvRow(const std::string& image, const Pose* p) { return image + "," + (p ? poseFields(*p) : std::string(",,,,,,")); }
std::string depthViewsCsvHeader() {
  return "view,x_mm,y_mm,z_mm,qw,qx,qy,qz,noisy_x_mm,noisy_y_mm,noisy_z_mm,noisy_qw,noisy_qx,noisy_qy,noisy_qz";
}
std::string depthViewsCsvRow(const std::string& view, const Pose& truth, const Pose& reported) {
  return view + "," + poseFields(truth) + "," + poseFields(reported);
}

Result<std::vector<DepthTruthRow>> loadDepthTruth(const std::string& path) {
  std::vector<int> lines;
  std::vector<std::string> fixed{"image"};
  fixed.insert(fixed.end(), kPoseColumns.begin(), kPoseColumns.end());
  auto rows = readCsv(path, fixed, lines);
  if (!rows) return std::unexpected(rows.error());
  std::vector<DepthTruthRow> out;
  std::map<std::string, std::pair<bool, int>> seen;  // image -> (has a part, first line)
  for (std::size_t i = 0; i < rows->size(); ++i) {
    const auto& f = (*rows)[i];
    const std::string where = fmt::format("{}:{}", path, lines[i]);
    DepthTruthRow r;
    r.image = f[0];
    r.line = lines[i];
    if (r.image.empty()) return fail(Status::BadArgument, where + ": empty image name");
    const bool allEmpty = std::all_of(f.begin() + 1, f.begin() + 8, [](const std::string& s) { return s.empty(); });
    if (!allEmpty) {
      auto pose = parsePose(f, 1, where, "");
      if (!pose) return std::unexpected(pose.error());
      r.pose = *pose;
      r.hasPart = true;
    }
    auto [it, added] = seen.emplace(r.image, std::make_pair(r.hasPart, r.line));
    if (!added && (!it->second.first || !r.hasPart))
      return fail(Status::BadArgument, fmt::format("{}: image '{}' has an empty row (line {}) and another row: an image without "
                                                   "a part has exactly one row",
                                                   where, r.image, it->second.second));
    out.push_back(r);
  }
  return out;
}

Result<std::vector<DepthViewRow>> loadDepthViews(const std::string& path) {
  std::vector<int> lines;
  std::vector<std::string> fixed{"view"};
  fixed.insert(fixed.end(), kPoseColumns.begin(), kPoseColumns.end());
  for (const auto& c : kPoseColumns) fixed.push_back("noisy_" + c);
  auto rows = readCsv(path, fixed, lines);
  if (!rows) return std::unexpected(rows.error());
  const auto dir = std::filesystem::path(path).parent_path();
  std::vector<DepthViewRow> out;
  for (std::size_t i = 0; i < rows->size(); ++i) {
    const auto& f = (*rows)[i];
    const std::string where = fmt::format("{}:{}", path, lines[i]);
    DepthViewRow r;
    r.view = f[0];
    r.line = lines[i];
    if (r.view.empty()) return fail(Status::BadArgument, where + ": empty view name");
    if (!std::filesystem::is_regular_file(dir / r.view))
      return fail(Status::BadArgument, fmt::format("{}: view '{}': no such file in {}", where, r.view, dir.empty() ? "." : dir.string()));
    auto t = parsePose(f, 1, where, "");
    if (!t) return std::unexpected(t.error());
    auto n = parsePose(f, 8, where, "noisy_");
    if (!n) return std::unexpected(n.error());
    r.truth = *t;
    r.reported = *n;
    out.push_back(r);
  }
  return out;
}

}  // namespace vgr::config
