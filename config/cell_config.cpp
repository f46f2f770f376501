#include "config/cell_config.hpp"

#include <algorithm>
#include <cmath>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>

#include <yaml-cpp/yaml.h>

namespace vgr::config {
namespace {

// Thrown inside the parser only; turned into an Error at the API boundary.
struct ConfigError {
  std::string message;
};

std::size_t editDistance(const std::string& a, const std::string& b) {
  std::vector<std::size_t> prev(b.size() + 1), cur(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) prev[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    cur[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j)
      cur[j] = std::min({prev[j] + 1, cur[j - 1] + 1, prev[j - 1] + (a[i - 1] == b[j - 1] ? 0u : 1u)});
    std::swap(prev, cur);
  }
  return prev[b.size()];
}

// Walks one YAML mapping, remembers which keys were read, and rejects the rest: a typo in
// a key is an error naming the line, never a silently ignored setting.
class Section {
 public:
  Section(const std::string& file, YAML::Node node, std::string path)
      : file_(file), node_(std::move(node)), path_(std::move(path)) {
    if (node_ && !node_.IsNull() && !node_.IsMap()) fail(node_, "", "expected a mapping");
  }

  [[noreturn]] void fail(const YAML::Node& at, const std::string& key, const std::string& what) const {
    std::ostringstream os;
    os << file_ << ':' << (at.Mark().line >= 0 ? at.Mark().line + 1 : 0) << ": key '" << join(key) << "': " << what;
    throw ConfigError{os.str()};
  }

  std::string join(const std::string& key) const {
    if (path_.empty()) return key;
    if (key.empty()) return path_;
    return path_ + "." + key;
  }

  YAML::Node get(const std::string& key) {
    known_.insert(key);
    if (!node_ || !node_.IsMap()) return YAML::Node();
    return node_[key];
  }

  template <class T>
  void read(const std::string& key, T& out, std::function<bool(const T&)> valid = nullptr,
            const std::string& range = "") {
    YAML::Node n = get(key);
    if (!n || n.IsNull()) return;  // absent or empty: keep the default
    T v{};
    try {
      v = n.as<T>();
    } catch (const YAML::Exception&) {
      fail(n, key, "expected " + typeName<T>() + (range.empty() ? "" : " in " + range) + ", got '" + scalar(n) + "'");
    }
    if constexpr (std::is_floating_point_v<T>) {
      if (!std::isfinite(v)) fail(n, key, "expected a finite number, got '" + scalar(n) + "'");
    }
    if (valid && !valid(v)) fail(n, key, "out of range: expected " + range + ", got '" + scalar(n) + "'");
    out = v;
  }

  void require(const std::string& key) {
    if (!node_ || !node_.IsMap() || !node_[key]) fail(node_, key, "required key is missing");
  }

  // After all reads: any key not read is unknown.
  void finish() const {
    if (!node_ || !node_.IsMap()) return;
    for (const auto& kv : node_) {
      const std::string k = kv.first.as<std::string>();
      if (known_.count(k)) continue;
      std::string best;
      std::size_t bestD = 3;
      for (const auto& cand : known_) {
        const std::size_t d = editDistance(k, cand);
        if (d < bestD) bestD = d, best = cand;
      }
      fail(kv.first, k, best.empty() ? "unknown key" : "unknown key (did you mean '" + best + "'?)");
    }
  }

  const YAML::Node& node() const { return node_; }
  const std::string& path() const { return path_; }
  const std::string& file() const { return file_; }

 private:
  static std::string scalar(const YAML::Node& n) { return n.IsScalar() ? n.Scalar() : std::string("<non-scalar>"); }
  template <class T>
  static std::string typeName() {
    if constexpr (std::is_same_v<T, bool>) return "true or false";
    else if constexpr (std::is_integral_v<T>) return "an integer";
    else if constexpr (std::is_floating_point_v<T>) return "a number";
    else return "a string";
  }

  std::string file_;
  YAML::Node node_;
  std::string path_;
  std::set<std::string> known_;
};

template <class T>
std::function<bool(const T&)> inRange(T lo, T hi) {
  return [lo, hi](const T& v) { return v >= lo && v <= hi; };
}

std::function<bool(const std::string&)> oneOf(std::initializer_list<const char*> names) {
  std::vector<std::string> v(names.begin(), names.end());
  return [v](const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); };
}

void parseCamera(Section s, CameraConfig& c) {
  s.read<std::string>("name", c.name);
  s.read<std::string>("driver", c.driver, oneOf({"aravis"}), "one of: aravis");
  s.read<std::string>("address", c.address);
  s.read<std::string>("serial", c.serial);
  s.read<int>("timeout_ms", c.timeoutMs, inRange(50, 60000), "[50, 60000]");
  s.read<double>("exposure_us", c.exposureUs, inRange(20.0, 1e6), "[20, 1000000]");
  s.read<int>("packet_size", c.packetSize, [](const int& v) { return v == 0 || (v >= 576 && v <= 65000); },
              "0 (negotiate) or [576, 65000]");
  s.read<int>("reconnect_min_ms", c.reconnectMinMs, inRange(10, 60000), "[10, 60000]");
  s.read<int>("reconnect_max_ms", c.reconnectMaxMs, inRange(10, 600000), "[10, 600000]");
  if (c.address.empty() && c.serial.empty()) s.fail(s.node(), "address", "a camera needs an address or a serial");
  if (c.reconnectMaxMs < c.reconnectMinMs)
    s.fail(s.get("reconnect_max_ms"), "reconnect_max_ms", "must not be below reconnect_min_ms");
  s.finish();
}

void parseModel(Section s, PlaneModelConfig& m) {
  auto positive = [](const double& v) { return v > 0; };
  s.read<double>("fx", m.fx, positive, "> 0");
  s.read<double>("fy", m.fy, positive, "> 0");
  s.read<double>("cx", m.cx);
  s.read<double>("cy", m.cy);
  s.read<double>("camera_x_mm", m.camX);
  s.read<double>("camera_y_mm", m.camY);
  s.read<double>("camera_z_mm", m.camZ);
  s.read<double>("camera_rz_deg", m.camRzDeg, inRange(-360.0, 360.0), "[-360, 360]");
  s.read<double>("plane_z_mm", m.planeZ);
  if (m.camZ <= m.planeZ) s.fail(s.get("camera_z_mm"), "camera_z_mm", "the camera must be above plane_z_mm");
  s.finish();
}

void parseModbus(Section s, ModbusConfig& m) {
  s.read<bool>("enabled", m.enabled);
  s.read<std::string>("bind", m.bind);
  int port = m.port;
  s.read<int>("port", port, inRange(1, 65535), "[1, 65535]");
  m.port = static_cast<std::uint16_t>(port);
  std::string order = "high_word_first";
  s.read<std::string>("float_word_order", order, oneOf({"high_word_first", "low_word_first"}),
                      "one of: high_word_first, low_word_first");
  m.floatWordOrder = order == "high_word_first" ? WordOrder::HighWordFirst : WordOrder::LowWordFirst;
  s.finish();
}

void parseRobot(Section s, RobotConfig& r) {
  s.require("name");
  s.require("port");
  s.read<std::string>("name", r.name);
  std::string dialect = "ur";
  s.read<std::string>("dialect", dialect, oneOf({"ur", "abb"}), "one of: ur, abb");
  r.dialect = dialect == "ur" ? Dialect::Ur : Dialect::Abb;
  s.read<std::string>("bind", r.bind);
  int port = 0;
  s.read<int>("port", port, inRange(1, 65535), "[1, 65535]");
  r.port = static_cast<std::uint16_t>(port);
  s.read<int>("reply_deadline_ms", r.replyDeadlineMs, inRange(50, 60000), "[50, 60000]");
  s.finish();
}

void parseJob(Section s, JobConfig& j) {
  s.require("id");
  s.read<int>("id", j.id, inRange(1, 32767), "[1, 32767]");
  s.read<std::string>("name", j.name);
  s.read<std::string>("method", j.method, oneOf({"moments"}), "one of: moments");
  s.read<int>("threshold", j.threshold, inRange(0, 255), "[0, 255]");
  s.read<double>("min_area_px", j.minAreaPx, [](const double& v) { return v > 0; }, "> 0");
  s.read<double>("max_area_px", j.maxAreaPx, [](const double& v) { return v > 0; }, "> 0");
  if (j.maxAreaPx <= j.minAreaPx) s.fail(s.get("max_area_px"), "max_area_px", "must be above min_area_px");
  s.read<double>("part_height_mm", j.partHeightMm, inRange(0.0, 1000.0), "[0, 1000]");
  s.read<double>("angle_offset_deg", j.angleOffsetDeg, inRange(-360.0, 360.0), "[-360, 360]");
  Section ref(s.file(), s.get("reference"), s.join("reference"));
  ref.read<double>("x_mm", j.reference.x);
  ref.read<double>("y_mm", j.reference.y);
  ref.read<double>("z_mm", j.reference.z);
  ref.read<double>("rz_deg", j.reference.rzDeg, inRange(-360.0, 360.0), "[-360, 360]");
  ref.finish();
  s.finish();
}

void parseSim(Section s, SimConfig& c) {
  int seed = static_cast<int>(c.seed);
  s.read<int>("seed", seed, inRange(0, std::numeric_limits<int>::max()), ">= 0");
  c.seed = static_cast<std::uint64_t>(seed);
  s.read<int>("width", c.width, inRange(64, 2448), "[64, 2448]");
  s.read<int>("height", c.height, inRange(64, 2048), "[64, 2048]");
  s.read<double>("noise_sigma", c.noiseSigma, inRange(0.0, 64.0), "[0, 64]");
  s.read<std::string>("serial", c.serial);
  s.finish();
}

CellConfig parse(const YAML::Node& root, const std::string& file) {
  CellConfig c;
  c.sourcePath = file;
  Section top(file, root, "");
  if (!root || root.IsNull()) top.fail(root, "", "the file is empty");

  Section cell(file, top.get("cell"), "cell");
  cell.read<std::string>("name", c.name);
  cell.read<std::string>("journal", c.journalPath);
  cell.read<std::string>("log_level", c.logLevel,
                         oneOf({"trace", "debug", "info", "warn", "error", "critical", "off"}),
                         "one of: trace, debug, info, warn, error, critical, off");
  cell.read<int>("cycle_deadline_ms", c.cycleDeadlineMs, inRange(100, 60000), "[100, 60000]");
  cell.finish();

  top.require("camera");
  parseCamera(Section(file, top.get("camera"), "camera"), c.camera);
  top.require("model");
  parseModel(Section(file, top.get("model"), "model"), c.model);
  parseModbus(Section(file, top.get("modbus"), "modbus"), c.modbus);

  const YAML::Node robots = top.get("robots");
  if (robots && !robots.IsSequence()) top.fail(robots, "robots", "expected a list");
  std::set<int> ports;
  if (c.modbus.enabled) ports.insert(c.modbus.port);
  for (std::size_t i = 0; robots && i < robots.size(); ++i) {
    RobotConfig r;
    const std::string path = "robots[" + std::to_string(i) + "]";
    parseRobot(Section(file, robots[i], path), r);
    if (!ports.insert(r.port).second) top.fail(robots[i]["port"], path + ".port", "port already used by another endpoint");
    c.robots.push_back(r);
  }

  top.require("jobs");
  const YAML::Node jobs = top.get("jobs");
  if (!jobs.IsSequence() || jobs.size() == 0) top.fail(jobs, "jobs", "expected a non-empty list");
  std::set<int> ids;
  for (std::size_t i = 0; i < jobs.size(); ++i) {
    JobConfig j;
    const std::string path = "jobs[" + std::to_string(i) + "]";
    parseJob(Section(file, jobs[i], path), j);
    if (!ids.insert(j.id).second) top.fail(jobs[i]["id"], path + ".id", "duplicate job id " + std::to_string(j.id));
    c.jobs.push_back(j);
  }

  parseSim(Section(file, top.get("sim"), "sim"), c.sim);
  top.finish();
  return c;
}

}  // namespace

const JobConfig* CellConfig::findJob(int id) const {
  for (const auto& j : jobs)
    if (j.id == id) return &j;
  return nullptr;
}

Result<CellConfig> parseCellConfig(const std::string& text, const std::string& sourceName) {
  try {
    return parse(YAML::Load(text), sourceName);
  } catch (const ConfigError& e) {
    return fail(Status::BadArgument, e.message);
  } catch (const YAML::Exception& e) {
    // Syntax errors: yaml-cpp's mark is 0-based.
    return fail(Status::BadArgument, sourceName + ":" + std::to_string(e.mark.line + 1) + ": YAML syntax error: " + e.msg);
  }
}

Result<CellConfig> loadCellConfig(const std::string& path) {
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open the config file");
  std::stringstream ss;
  ss << in.rdbuf();
  return parseCellConfig(ss.str(), path);
}

}  // namespace vgr::config
