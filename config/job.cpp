#include "config/job.hpp"

#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

namespace vgr::config {
namespace {

// Thrown inside the parser only; turned into an Error at the API boundary.
struct JobError {
  std::string message;
};

// A small reader in the manner of cell_config.cpp's Section (kept separate so the two files
// can change independently): remembers the keys read and rejects unknown ones; every error
// names file, line and key path.
class Reader {
 public:
  Reader(std::string file, YAML::Node node, std::string path) : file_(std::move(file)), node_(std::move(node)), path_(std::move(path)) {
    if (node_ && !node_.IsNull() && !node_.IsMap()) fail(node_, "", "expected a mapping");
  }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key, const std::string& what) const {
    const int line = at.Mark().line >= 0 ? at.Mark().line + 1 : (node_.Mark().line >= 0 ? node_.Mark().line + 1 : 0);
    throw JobError{fmt::format("{}:{}: key '{}': {}", file_, line, join(key), what)};
  }
  std::string join(const std::string& key) const {
    if (path_.empty()) return key;
    if (key.empty()) return path_;
    return key.front() == '[' ? path_ + key : path_ + "." + key;
  }
  YAML::Node get(const std::string& key) {
    known_.insert(key);
    if (!node_ || !node_.IsMap()) return YAML::Node();
    return node_[key];
  }
  bool has(const std::string& key) { return get(key) && !get(key).IsNull(); }

  double number(const std::string& key, double fallback, double lo, double hi) {
    const YAML::Node n = get(key);
    if (!n || n.IsNull()) return fallback;
    return numberOf(n, key, lo, hi);
  }
  double numberOf(const YAML::Node& n, const std::string& key, double lo, double hi) const {
    double v = 0;
    try {
      v = n.as<double>();
    } catch (const YAML::Exception&) {
      fail(n, key, fmt::format("expected a number in [{}, {}], got '{}'", lo, hi, scalar(n)));
    }
    if (!std::isfinite(v) || v < lo || v > hi) fail(n, key, fmt::format("expected a number in [{}, {}], got '{}'", lo, hi, scalar(n)));
    return v;
  }
  int integer(const std::string& key, int fallback, int lo, int hi) {
    const YAML::Node n = get(key);
    if (!n || n.IsNull()) return fallback;
    int v = 0;
    try {
      v = n.as<int>();
    } catch (const YAML::Exception&) {
      fail(n, key, fmt::format("expected an integer in [{}, {}], got '{}'", lo, hi, scalar(n)));
    }
    if (v < lo || v > hi) fail(n, key, fmt::format("expected an integer in [{}, {}], got '{}'", lo, hi, scalar(n)));
    return v;
  }
  std::string text(const std::string& key, const std::string& fallback) {
    const YAML::Node n = get(key);
    if (!n || n.IsNull()) return fallback;
    if (!n.IsScalar()) fail(n, key, "expected a string");
    return n.Scalar();
  }
  void finish() const {
    if (!node_ || !node_.IsMap()) return;
    for (const auto& kv : node_) {
      const std::string k = kv.first.as<std::string>();
      if (!known_.count(k)) fail(kv.first, k, "unknown key");
    }
  }
  const std::string& file() const { return file_; }
  const YAML::Node& node() const { return node_; }

  static std::string scalar(const YAML::Node& n) { return n.IsScalar() ? n.Scalar() : std::string("<non-scalar>"); }

 private:
  std::string file_;
  YAML::Node node_;
  std::string path_;
  std::set<std::string> known_;
};

std::vector<vision::TemplateRegion> parseRegions(Reader& top, const YAML::Node& list) {
  std::vector<vision::TemplateRegion> out;
  if (!list || list.IsNull()) return out;
  if (!list.IsSequence()) top.fail(list, "regions", "expected a list of {height_mm, height_factor, polygon}");
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string path = fmt::format("regions[{}]", i);
    Reader r(top.file(), list[i], path);
    vision::TemplateRegion reg;
    reg.heightMm = r.number("height_mm", 0, 0, 1000);
    reg.heightFactor = r.number("height_factor", 1, 0, 1);
    const YAML::Node poly = r.get("polygon");
    if (!poly || !poly.IsSequence() || poly.size() < 3) r.fail(poly ? poly : list[i], "polygon", "expected a list of at least 3 points [x_px, y_px]");
    for (std::size_t k = 0; k < poly.size(); ++k) {
      const std::string key = fmt::format("polygon[{}]", k);
      if (!poly[k].IsSequence() || poly[k].size() != 2) r.fail(poly[k], key, "expected a point [x_px, y_px]");
      reg.polygon.push_back({r.numberOf(poly[k][0], key, -1e6, 1e6), r.numberOf(poly[k][1], key, -1e6, 1e6)});
    }
    r.finish();
    out.push_back(std::move(reg));
  }
  return out;
}

JobFile parse(const YAML::Node& root, const std::string& file, const std::string& folder) {
  Reader top(file, root, "");
  if (!root || root.IsNull()) top.fail(root, "", "the file is empty");
  JobFile j;
  j.folder = folder;
  const int version = top.integer("version", 1, 1, 1);
  (void)version;
  j.name = top.text("name", "");
  j.method = top.text("method", j.method);
  if (j.method.empty()) top.fail(top.get("method"), "method", "must not be empty");
  j.templateImage = top.text("template", j.templateImage);

  const YAML::Node grasps = top.get("grasps");
  if (!grasps || !grasps.IsSequence() || grasps.size() == 0)
    top.fail(grasps ? grasps : root, "grasps", "expected a non-empty list of {x_px, y_px}");
  for (std::size_t i = 0; i < grasps.size(); ++i) {
    Reader g(file, grasps[i], fmt::format("grasps[{}]", i));
    if (!g.has("x_px") || !g.has("y_px")) g.fail(grasps[i], "", "expected {x_px, y_px}");
    j.grasps.push_back({g.number("x_px", 0, -1e6, 1e6), g.number("y_px", 0, -1e6, 1e6)});
    g.finish();
  }
  j.taught.grasp = j.grasps.front();

  Reader roi(file, top.get("roi"), "roi");
  j.taught.searchRoi.x = roi.integer("x", 0, 0, 65535);
  j.taught.searchRoi.y = roi.integer("y", 0, 0, 65535);
  j.taught.searchRoi.width = roi.integer("width", 0, 0, 65535);
  j.taught.searchRoi.height = roi.integer("height", 0, 0, 65535);
  roi.finish();

  j.taught.minScore = top.number("min_score", j.taught.minScore, 0, 1);
  j.taught.maxParts = top.integer("max_parts", j.taught.maxParts, 1, 64);
  j.taught.angleMinDeg = top.number("angle_min_deg", j.taught.angleMinDeg, -180, 180);
  j.taught.angleMaxDeg = top.number("angle_max_deg", j.taught.angleMaxDeg, -180, 180);
  if (j.taught.angleMaxDeg < j.taught.angleMinDeg) top.fail(top.get("angle_max_deg"), "angle_max_deg", "must not be below angle_min_deg");
  j.partHeightMm = top.number("part_height_mm", 0, 0, 1000);

  Reader ref(file, top.get("reference"), "reference");
  j.referenceXMm = ref.number("x_mm", 0, -1e6, 1e6);
  j.referenceYMm = ref.number("y_mm", 0, -1e6, 1e6);
  j.referenceZMm = ref.number("z_mm", 0, -1e6, 1e6);
  j.referenceRzDeg = ref.number("rz_deg", 0, -360, 360);
  ref.finish();
  j.calibration = top.text("calibration", "");

  const YAML::Node params = top.get("params");
  if (params && !params.IsNull()) {
    if (!params.IsMap()) top.fail(params, "params", "expected a mapping of parameter: value");
    for (const auto& kv : params) {
      if (!kv.second.IsScalar()) top.fail(kv.second, "params." + kv.first.as<std::string>(), "expected a single value");
      j.taught.params[kv.first.as<std::string>()] = kv.second.Scalar();
    }
  }
  j.taught.regions = parseRegions(top, top.get("regions"));
  top.finish();
  return j;
}

std::string fmtNum(double v) {
  std::string s = fmt::format("{:.4f}", v);
  while (s.size() > 1 && s.back() == '0') s.pop_back();
  if (s.back() == '.') s.pop_back();
  return s == "-0" ? "0" : s;
}

}  // namespace

std::string JobFile::templatePath() const { return (std::filesystem::path(folder) / templateImage).string(); }
std::string JobFile::calibrationPath() const {
  return calibration.empty() ? std::string() : (std::filesystem::path(folder) / calibration).string();
}

Result<JobFile> parseJob(const std::string& text, const std::string& sourceName, const std::string& folder) {
  try {
    return parse(YAML::Load(text), sourceName, folder);
  } catch (const JobError& e) {
    return fail(Status::BadArgument, e.message);
  } catch (const YAML::Exception& e) {
    return fail(Status::BadArgument, fmt::format("{}:{}: YAML syntax error: {}", sourceName, e.mark.line + 1, e.msg));
  }
}

Result<JobFile> loadJob(const std::string& folder) {
  const std::string path = (std::filesystem::path(folder) / "job.yaml").string();
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open the job file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parseJob(ss.str(), path, folder);
}

std::string jobYaml(const JobFile& j) {
  std::string y = "# vgr job (docs/localization.md \"Jobs\"). Pixels: template px, x right, y down,\n"
                  "# pixel centres at integers; angles in degrees, counter-clockwise as displayed.\n";
  y += "version: 1\n";
  y += fmt::format("name: \"{}\"\n", j.name);
  y += fmt::format("method: {}\n", j.method);
  y += fmt::format("template: {}\n", j.templateImage);
  y += "grasps:                     # the first is the one transferred into live images\n";
  for (const auto& g : j.grasps) y += fmt::format("  - {{x_px: {}, y_px: {}}}\n", fmtNum(g.u), fmtNum(g.v));
  const auto& r = j.taught.searchRoi;
  y += fmt::format("roi: {{x: {}, y: {}, width: {}, height: {}}}   # search region in live images; 0 x 0 = whole image\n",
                   r.x, r.y, r.width, r.height);
  y += fmt::format("min_score: {}              # [0, 1]: weaker candidates are not parts\n", fmtNum(j.taught.minScore));
  y += fmt::format("max_parts: {}               # [1, 64]\n", j.taught.maxParts);
  y += fmt::format("angle_min_deg: {}\nangle_max_deg: {}\n", fmtNum(j.taught.angleMinDeg), fmtNum(j.taught.angleMaxDeg));
  y += fmt::format("part_height_mm: {}          # grasp height above the conveyor plane\n", fmtNum(j.partHeightMm));
  y += fmt::format("reference: {{x_mm: {}, y_mm: {}, z_mm: {}, rz_deg: {}}}   # taught robot pose (base frame)\n",
                   fmtNum(j.referenceXMm), fmtNum(j.referenceYMm), fmtNum(j.referenceZMm), fmtNum(j.referenceRzDeg));
  y += fmt::format("calibration: \"{}\"            # a cell config whose model maps px -> mm; empty = pixels only\n", j.calibration);
  y += "# The method's parameters by name (docs/localization.md); unknown names are an error.\n";
  y += j.taught.params.empty() ? "params: {}\n" : "params:\n";
  for (const auto& [k, v] : j.taught.params) y += fmt::format("  {}: \"{}\"\n", k, v);
  y += "# Contour regions of paper 000 (eqs. 3-4): top faces in template px with their height and\n"
       "# height factor (1 at the grasp point's height, far less than 1 elsewhere). Edit freely.\n";
  y += "regions:";
  if (j.taught.regions.empty()) y += " []";
  y += "\n";
  for (const auto& reg : j.taught.regions) {
    y += fmt::format("  - height_mm: {}\n    height_factor: {}\n    polygon: [", fmtNum(reg.heightMm), fmtNum(reg.heightFactor));
    for (std::size_t i = 0; i < reg.polygon.size(); ++i)
      y += fmt::format("{}[{}, {}]", i ? ", " : "", fmtNum(reg.polygon[i].u), fmtNum(reg.polygon[i].v));
    y += "]\n";
  }
  return y;
}

Result<void> writeJob(const JobFile& j) {
  const std::string path = (std::filesystem::path(j.folder) / "job.yaml").string();
  std::ofstream out(path);
  out << jobYaml(j);
  out.close();
  if (!out) return fail(Status::Internal, path + ": cannot write");
  return {};
}

Result<std::vector<vision::TemplateRegion>> loadRegions(const std::string& path) {
  try {
    const YAML::Node root = YAML::LoadFile(path);
    if (!root.IsMap()) return fail(Status::BadArgument, path + ": expected a mapping with a 'regions' list");
    Reader top(path, root, "");
    return parseRegions(top, top.get("regions"));
  } catch (const JobError& e) {
    return fail(Status::BadArgument, e.message);
  } catch (const YAML::BadFile&) {
    return fail(Status::BadArgument, path + ": cannot open");
  } catch (const YAML::Exception& e) {
    return fail(Status::BadArgument, fmt::format("{}:{}: YAML syntax error: {}", path, e.mark.line + 1, e.msg));
  }
}

}  // namespace vgr::config
