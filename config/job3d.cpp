#include "config/job3d.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

#include "config/yaml_section.hpp"

namespace vgr::config {
namespace {

std::string numberText(double v) { return v == 0 ? std::string("0") : fmt::format("{}", v); }

Job3dFile parse(const YAML::Node& root, const std::string& file, const std::string& folder) {
  Section top(file, root, "");
  if (!root || root.IsNull()) top.fail(root, "", "the file is empty");
  Job3dFile j;
  j.folder = folder;
  top.integer("version", 1, 1, 1);
  top.require("kind");
  if (top.text("kind", "") != "3d") top.fail(top.get("kind"), "kind", "expected 3d for a 3D job");
  j.name = top.text("name", "");
  j.model = top.text("model", j.model);
  if (j.model.empty()) top.fail(top.get("model"), "model", "expected a file name (the model cloud, PLY)");

  Section g(file, top.get("grasp"), "grasp");
  j.grasp.x = g.number("x_mm", 0, -1e5, 1e5);
  j.grasp.y = g.number("y_mm", 0, -1e5, 1e5);
  j.grasp.z = g.number("z_mm", 0, -1e5, 1e5);
  j.grasp.qw = g.number("qw", 1, -1, 1);
  j.grasp.qx = g.number("qx", 0, -1, 1);
  j.grasp.qy = g.number("qy", 0, -1, 1);
  j.grasp.qz = g.number("qz", 0, -1, 1);
  const double n = std::sqrt(j.grasp.qw * j.grasp.qw + j.grasp.qx * j.grasp.qx + j.grasp.qy * j.grasp.qy + j.grasp.qz * j.grasp.qz);
  if (std::abs(n - 1) > 1e-3)
    g.fail(g.get("qw") ? g.get("qw") : top.get("grasp"), "qw", fmt::format("the quaternion is not unit length (|q| = {:.6f})", n));
  j.grasp.qw /= n, j.grasp.qx /= n, j.grasp.qy /= n, j.grasp.qz /= n;
  g.finish();

  Section s(file, top.get("search"), "search");
  for (const auto& key : search3dKeys()) {
    const double fallback = key.get(j.search);
    key.set(j.search, key.integer ? s.integer(key.name, static_cast<int>(fallback), static_cast<int>(key.lo), static_cast<int>(key.hi))
                                  : s.number(key.name, fallback, key.lo, key.hi));
  }
  s.read<bool>("remove_plane", j.search.removePlane);
  j.search.seed = static_cast<unsigned>(s.integer("seed", static_cast<int>(j.search.seed), 0, 2147483647));
  Section r(file, s.get("roi"), "search.roi");
  auto& roi = j.search.roi;
  roi.xMin = r.number("x_min", roi.xMin, -1e5, 1e5);
  roi.xMax = r.number("x_max", roi.xMax, -1e5, 1e5);
  roi.yMin = r.number("y_min", roi.yMin, -1e5, 1e5);
  roi.yMax = r.number("y_max", roi.yMax, -1e5, 1e5);
  roi.zMin = r.number("z_min", roi.zMin, -1e5, 1e5);
  roi.zMax = r.number("z_max", roi.zMax, -1e5, 1e5);
  r.finish();
  if (const std::string e = search3dCrossCheck(j.search); !e.empty()) {
    const std::string key = e.substr(0, e.find(':'));
    const YAML::Node at = s.get(key);
    s.fail(at ? at : top.get("search"), key, e.substr(e.find(':') + 2));
  }
  s.finish();
  top.finish();
  return j;
}

}  // namespace

std::string Job3dFile::modelPath() const { return (std::filesystem::path(folder) / model).string(); }

Result<std::string> jobKind(const std::string& folder) {
  const std::string path = (std::filesystem::path(folder) / "job.yaml").string();
  if (!std::filesystem::is_regular_file(path)) return fail(Status::BadArgument, path + ": cannot open the job file");
  return readYamlFile<std::string>(path, [&](const YAML::Node& root) -> std::string {
    if (!root.IsMap()) return "2d";  // the 2D reader says what is wrong with it
    const YAML::Node k = root["kind"];
    if (!k || k.IsNull()) return "2d";
    const std::string kind = k.IsScalar() ? k.Scalar() : "";
    if (kind != "2d" && kind != "3d")
      throw SectionError{fmt::format("{}:{}: key 'kind': expected 2d or 3d, got '{}'", path, k.Mark().line + 1, Section::scalar(k))};
    return kind;
  });
}

Result<Job3dFile> parseJob3d(const std::string& text, const std::string& sourceName, const std::string& folder) {
  try {
    failOnInvalidUtf8(sourceName, text);
    return parse(YAML::Load(text), sourceName, folder);
  } catch (const SectionError& e) {
    return fail(Status::BadArgument, e.message);
  } catch (const YAML::Exception& e) {
    return fail(Status::BadArgument, fmt::format("{}:{}: YAML syntax error: {}", sourceName, e.mark.line + 1, e.msg));
  }
}

Result<Job3dFile> loadJob3d(const std::string& folder) {
  const std::string path = (std::filesystem::path(folder) / "job.yaml").string();
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open the job file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parseJob3d(ss.str(), path, folder);
}

std::string job3dYaml(const Job3dFile& j) {
  YAML::Emitter y;
  y << YAML::Comment("vgr 3D job (docs/3d.md \"Jobs\"): mm, degrees; poses as mm + unit quaternion (w, x, y, z).");
  y << YAML::BeginMap;
  y << YAML::Key << "version" << YAML::Value << 1;
  y << YAML::Key << "kind" << YAML::Value << "3d";
  y << YAML::Key << "name" << YAML::Value << j.name;
  y << YAML::Key << "model" << YAML::Value << j.model << YAML::Comment("x y z nx ny nz, mm, model frame");
  const Pose& g = j.grasp;
  y << YAML::Key << "grasp" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x_mm" << YAML::Value << numberText(g.x)
    << YAML::Key << "y_mm" << YAML::Value << numberText(g.y) << YAML::Key << "z_mm" << YAML::Value << numberText(g.z) << YAML::Key
    << "qw" << YAML::Value << numberText(g.qw) << YAML::Key << "qx" << YAML::Value << numberText(g.qx) << YAML::Key << "qy"
    << YAML::Value << numberText(g.qy) << YAML::Key << "qz" << YAML::Value << numberText(g.qz) << YAML::EndMap
    << YAML::Comment("gripper frame in the model frame (T_model_grasp)");
  y << YAML::Newline << YAML::Comment("Search (paper 004 Sec. 3.2 and 5; docs/3d.md \"Parameters\"). ROI in the camera frame, mm.");
  y << YAML::Key << "search" << YAML::Value << YAML::BeginMap;
  for (const auto& key : search3dKeys()) {
    const double v = key.get(j.search);
    y << YAML::Key << key.name << YAML::Value << (key.integer ? fmt::format("{}", static_cast<long long>(v)) : numberText(v));
  }
  y << YAML::Key << "remove_plane" << YAML::Value << j.search.removePlane;
  y << YAML::Key << "seed" << YAML::Value << j.search.seed;
  const auto& r = j.search.roi;
  y << YAML::Key << "roi" << YAML::Value << YAML::Flow << YAML::BeginMap << YAML::Key << "x_min" << YAML::Value << numberText(r.xMin)
    << YAML::Key << "x_max" << YAML::Value << numberText(r.xMax) << YAML::Key << "y_min" << YAML::Value << numberText(r.yMin)
    << YAML::Key << "y_max" << YAML::Value << numberText(r.yMax) << YAML::Key << "z_min" << YAML::Value << numberText(r.zMin)
    << YAML::Key << "z_max" << YAML::Value << numberText(r.zMax) << YAML::EndMap;
  y << YAML::EndMap << YAML::EndMap;
  return std::string(y.c_str()) + "\n";
}

Result<void> writeJob3d(const Job3dFile& j) { return writeTextFile((std::filesystem::path(j.folder) / "job.yaml").string(), job3dYaml(j)); }

}  // namespace vgr::config
