#include "config/cell_config.hpp"

#include <arpa/inet.h>
#include <sys/socket.h>

#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <functional>
#include <limits>
#include <set>
#include <sstream>

#include <fmt/core.h>
#include <yaml-cpp/yaml.h>

#include "config/job.hpp"
#include "config/job3d.hpp"
#include "config/yaml_section.hpp"

namespace vgr::config {
namespace {

template <class T>
std::function<bool(const T&)> inRange(T lo, T hi) {
  return [lo, hi](const T& v) { return v >= lo && v <= hi; };
}

std::function<bool(const std::string&)> oneOf(std::initializer_list<const char*> names) {
  std::vector<std::string> v(names.begin(), names.end());
  return [v](const std::string& s) { return std::find(v.begin(), v.end(), s) != v.end(); };
}

// `key: [min, max]`: two finite numbers with -bound <= min <= max <= bound.
void readInterval(Section& s, const std::string& key, std::optional<Interval>& out, double bound) {
  const YAML::Node n = s.get(key);
  if (!n || n.IsNull()) return;
  const std::string expect = fmt::format("expected [min, max] with {:g} <= min <= max <= {:g}", -bound, bound);
  if (!n.IsSequence() || n.size() != 2) s.fail(n, key, expect + ", got '" + (n.IsScalar() ? n.Scalar() : "a list or map") + "'");
  double v[2] = {0, 0};
  for (std::size_t i = 0; i < 2; ++i) {
    try {
      v[i] = n[i].as<double>();
    } catch (const YAML::Exception&) {
      s.fail(n[i], key, expect + ", got '" + Section::scalar(n[i]) + "'");
    }
    if (!std::isfinite(v[i]) || v[i] < -bound || v[i] > bound) s.fail(n[i], key, expect + ", got '" + Section::scalar(n[i]) + "'");
  }
  if (v[0] > v[1]) s.fail(n, key, fmt::format("min {:g} is above max {:g}", v[0], v[1]));
  out = Interval{v[0], v[1]};
}

void parsePoseLimits(Section s, PoseLimits& p) {
  constexpr double kMm = 1e6, kDeg = 180;
  readInterval(s, "x_mm", p.x, kMm);
  readInterval(s, "y_mm", p.y, kMm);
  readInterval(s, "z_mm", p.z, kMm);
  readInterval(s, "rx_deg", p.rx, kDeg);
  readInterval(s, "ry_deg", p.ry, kDeg);
  readInterval(s, "rz_deg", p.rz, kDeg);
  s.finish();
}

// jobs[].limits: {offset: {x_mm: [lo, hi], ...}, work_area: {...}} (core/pose_limits.hpp).
void parseLimits(Section s, JobLimits& l) {
  parsePoseLimits(Section(s.file(), s.get("offset"), s.join("offset")), l.offset);
  parsePoseLimits(Section(s.file(), s.get("work_area"), s.join("work_area")), l.workArea);
  s.finish();
}

void parseCamera(Section s, CameraConfig& c) {
  s.read<std::string>("name", c.name);
  s.read<std::string>("driver", c.driver, oneOf({"aravis", "replay"}), "one of: aravis, replay");
  s.read<std::string>("address", c.address);
  s.read<std::string>("serial", c.serial);
  s.read<std::string>("user_name", c.userName);
  s.read<int>("timeout_ms", c.timeoutMs, inRange(50, 60000), "[50, 60000]");
  s.read<int>("retries", c.retries, inRange(0, 10), "[0, 10]");
  s.read<double>("exposure_us", c.exposureUs, inRange(10.0, 1e8), "[10, 100000000]");
  s.read<double>("gain", c.gain);
  s.read<std::string>("pixel_format", c.pixelFormat,
                      oneOf({"Mono8", "Mono10", "Mono12", "Mono16", "BayerRG8", "BayerGR8", "BayerGB8", "BayerBG8",
                             "Coord3D_C16"}),
                      "one of: Mono8, Mono10, Mono12, Mono16, BayerRG8, BayerGR8, BayerGB8, BayerBG8, Coord3D_C16");
  Section roi(s.file(), s.get("roi"), s.join("roi"));
  roi.read<int>("x", c.roiX, inRange(0, 65535), "[0, 65535]");
  roi.read<int>("y", c.roiY, inRange(0, 65535), "[0, 65535]");
  roi.read<int>("width", c.roiWidth, inRange(0, 65535), "0 (rest of the sensor) or [1, 65535]");
  roi.read<int>("height", c.roiHeight, inRange(0, 65535), "0 (rest of the sensor) or [1, 65535]");
  roi.finish();
  s.read<int>("packet_size", c.packetSize, [](const int& v) { return v == 0 || (v >= 576 && v <= 65000); },
              "0 (negotiate) or [576, 65000]");
  s.read<int>("packet_delay_ns", c.packetDelayNs, inRange(0, 1000000000), "[0, 1000000000]");
  s.read<int>("socket_buffer_bytes", c.socketBufferBytes,
              [](const int& v) { return v == 0 || (v >= 65536 && v <= (1 << 30)); }, "0 (auto) or [65536, 1073741824]");
  s.read<bool>("packet_resend", c.packetResend);
  s.read<int>("buffers", c.bufferCount, inRange(2, 64), "[2, 64]");
  Section trig(s.file(), s.get("trigger"), s.join("trigger"));
  std::string mode = "software";
  trig.read<std::string>("mode", mode, oneOf({"software", "hardware", "free_run"}), "one of: software, hardware, free_run");
  c.trigger = mode == "software" ? TriggerMode::Software : mode == "hardware" ? TriggerMode::Hardware : TriggerMode::FreeRun;
  trig.read<std::string>("line", c.triggerLine);
  trig.read<std::string>("activation", c.triggerActivation,
                         oneOf({"RisingEdge", "FallingEdge", "AnyEdge", "LevelHigh", "LevelLow"}),
                         "one of: RisingEdge, FallingEdge, AnyEdge, LevelHigh, LevelLow");
  trig.read<double>("delay_us", c.triggerDelayUs, inRange(0.0, 1e6), "[0, 1000000]");
  trig.finish();
  Section replay(s.file(), s.get("replay"), s.join("replay"));
  replay.read<std::string>("folder", c.replayFolder);
  replay.read<bool>("loop", c.replayLoop);
  replay.finish();
  s.read<int>("reconnect_min_ms", c.reconnectMinMs, inRange(10, 60000), "[10, 60000]");
  s.read<int>("reconnect_max_ms", c.reconnectMaxMs, inRange(10, 600000), "[10, 600000]");
  if (c.driver == "aravis" && c.address.empty() && c.serial.empty() && c.userName.empty())
    s.fail(s.node(), "address", "an aravis camera needs an address, a serial or a user_name");
  if (c.driver == "replay" && c.replayFolder.empty())
    s.fail(s.node(), "replay.folder", "a replay camera needs the folder of its images");
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

// The Modbus server binds and the client connects to a numeric IPv4 address (no resolver):
// a host name is refused here, not at start.
void readIpv4(Section& s, const std::string& key, std::string& out, const char* role) {
  s.read<std::string>(key, out);
  in_addr a{};
  if (::inet_pton(AF_INET, out.c_str(), &a) != 1)
    s.fail(s.get(key), key,
           fmt::format("expected a numeric IPv4 address ({}; 127.0.0.1 for this machine only, 0.0.0.0 for every "
                       "interface), got '{}'",
                       role, out));
}

// A list of numeric IP addresses (IPv4 only when v4Only): `key: [a, b]`; absent or null
// leaves `out` empty.
void readAddressList(Section& s, const std::string& key, std::vector<std::string>& out, bool v4Only) {
  const YAML::Node list = s.get(key);
  if (!list || list.IsNull()) return;
  const char* what = v4Only ? "IPv4 addresses" : "IP addresses";
  if (!list.IsSequence()) s.fail(list, key, fmt::format("expected a list of numeric {}", what));
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::string item = key + "[" + std::to_string(i) + "]";
    const std::string text = list[i].IsScalar() ? list[i].Scalar() : std::string("<non-scalar>");
    unsigned char buf[16];
    const bool ok = list[i].IsScalar() && (::inet_pton(AF_INET, text.c_str(), buf) == 1 ||
                                           (!v4Only && ::inet_pton(AF_INET6, text.c_str(), buf) == 1));
    if (!ok) s.fail(list[i], item, fmt::format("expected a numeric {} address, got '{}'", v4Only ? "IPv4" : "IP", text));
    out.push_back(text);
  }
}

// max_clients_per_address: [1, max_clients]; absent = min(kDefaultMaxClientsPerAddress, max_clients).
void readPerAddress(Section& s, int maxClients, int& out) {
  out = std::min(kDefaultMaxClientsPerAddress, maxClients);
  s.read<int>("max_clients_per_address", out, inRange(1, 64), "[1, 64]");
  if (out > maxClients)
    s.fail(s.get("max_clients_per_address"), "max_clients_per_address",
           fmt::format("{} is more than max_clients ({})", out, maxClients));
}

void parseModbus(Section s, ModbusConfig& m) {
  s.read<bool>("enabled", m.enabled);
  readIpv4(s, "bind", m.bind, "the Modbus server binds IPv4 addresses, it resolves no names");
  int port = m.port;
  s.read<int>("port", port, inRange(1, 65535), "[1, 65535]");
  m.port = static_cast<std::uint16_t>(port);
  std::string order = "high_word_first";
  s.read<std::string>("float_word_order", order, oneOf({"high_word_first", "low_word_first"}),
                      "one of: high_word_first, low_word_first");
  m.floatWordOrder = order == "high_word_first" ? WordOrder::HighWordFirst : WordOrder::LowWordFirst;
  s.read<int>("max_clients", m.maxClients, inRange(1, 64), "[1, 64]");
  readPerAddress(s, m.maxClients, m.maxClientsPerAddress);
  s.read<int>("idle_timeout_ms", m.idleTimeoutMs, inRange(0, 86400000), "[0, 86400000]");
  readAddressList(s, "allowed_clients", m.allowedClients, true);
  readAddressList(s, "control_clients", m.controlClients, true);
  s.read<bool>("require_trigger_enable", m.requireTriggerEnable);

  Section c(s.file(), s.get("client"), s.join("client"));
  ModbusClientConfig& mc = m.client;
  c.read<bool>("enabled", mc.enabled);
  readIpv4(c, "host", mc.host, "the PLC's address; names are not resolved");
  int clientPort = mc.port;
  c.read<int>("port", clientPort, inRange(1, 65535), "[1, 65535]");
  mc.port = static_cast<std::uint16_t>(clientPort);
  c.read<int>("unit_id", mc.unitId, inRange(0, 247), "[0, 247]");
  std::string trigger = "discrete_input";
  c.read<std::string>("trigger", trigger, oneOf({"discrete_input", "coil"}), "one of: discrete_input, coil");
  mc.trigger = trigger == "coil" ? TriggerInputKind::Coil : TriggerInputKind::DiscreteInput;
  c.read<int>("trigger_address", mc.triggerAddress, inRange(0, 65535), "[0, 65535]");
  c.read<int>("status_address", mc.statusAddress, inRange(0, 65506), "[0, 65506]");
  c.read<int>("poll_ms", mc.pollMs, inRange(1, 1000), "[1, 1000]");
  c.read<int>("debounce_ms", mc.debounceMs, inRange(0, 10000), "[0, 10000]");
  c.read<int>("job", mc.job, inRange(0, 32767), "[0, 32767]");
  c.read<int>("reconnect_ms", mc.reconnectMs, inRange(10, 60000), "[10, 60000]");
  c.finish();
  s.finish();
}

// A token of the strict dialect: 1..64 printable ASCII characters, none of which a robot
// program could use as a separator (space, ',', '#', CR, LF).
bool validToken(const std::string& t) {
  if (t.empty() || t.size() > 64) return false;
  for (char c : t) {
    if (c <= 0x20 || c >= 0x7F || c == ',' || c == '#') return false;
  }
  return true;
}

// A user frame's name as robot programs spell them: "wobj0", "UFRAME[1]", "Conveyor 2".
bool validFrameName(const std::string& t) {
  if (t.empty() || t.size() > 32) return false;
  for (char c : t)
    if (c < 0x20 || c >= 0x7F) return false;
  return true;
}

// The address in its canonical text (inet_ntop of inet_pton), "" when it is not one.
std::string normalIpAddress(const std::string& text) {
  unsigned char buf[16];
  char out[INET6_ADDRSTRLEN] = {};
  if (::inet_pton(AF_INET, text.c_str(), buf) == 1) return ::inet_ntop(AF_INET, buf, out, sizeof out) ? out : "";
  if (::inet_pton(AF_INET6, text.c_str(), buf) == 1) return ::inet_ntop(AF_INET6, buf, out, sizeof out) ? out : "";
  return "";
}

bool validIpAddress(const std::string& text) {
  unsigned char buf[16];
  return ::inet_pton(AF_INET, text.c_str(), buf) == 1 || ::inet_pton(AF_INET6, text.c_str(), buf) == 1;
}

// A token a pose frame follows: no '(' or '[' either (the frame starts with one).
bool validFrameToken(const std::string& t) {
  return validToken(t) && t.find_first_of("([)]") == std::string::npos;
}

void parseStrict(Section s, StrictConfig& c) {
  const std::string tokenRange = "1 to 64 printable characters without spaces, ',' or '#'";
  s.read<std::string>("command", c.command, validToken, tokenRange);
  s.read<std::string>("ready", c.ready, validToken, tokenRange);
  s.read<std::string>("done", c.done, validToken, tokenRange);
  const std::string frameTokenRange = "1 to 64 printable characters without spaces, ',', '#', brackets or parentheses";
  s.read<std::string>("snapshot", c.snapshot, validFrameToken, frameTokenRange);
  s.read<std::string>("none", c.none, validFrameToken, frameTokenRange);
  std::string lineEnd = "none";
  s.read<std::string>("line_end", lineEnd, oneOf({"none", "lf", "crlf"}), "one of: none, lf, crlf");
  c.lineEnd = lineEnd == "lf" ? "\n" : lineEnd == "crlf" ? "\r\n" : "";
  s.read<int>("step_timeout_ms", c.stepTimeoutMs, inRange(50, 600000), "[50, 600000]");
  if (c.ready == c.done) s.fail(s.get("done"), "done", "must differ from ready");
  if (!c.snapshot.empty() && (c.snapshot == c.ready || c.snapshot == c.done))
    s.fail(s.get("snapshot"), "snapshot", "must differ from ready and done");
  s.finish();
}

void parseRobot(Section s, RobotConfig& r) {
  s.require("name");
  s.require("port");
  s.read<std::string>("name", r.name);
  std::string dialect = "ur";
  s.read<std::string>("dialect", dialect, oneOf({"ur", "abb", "fanuc", "binary", "strict"}),
                      "one of: ur, abb, fanuc, binary, strict");
  r.dialect = *protocol::parseDialect(dialect);  // oneOf() accepted exactly the names parseDialect knows
  s.read<std::string>("bind", r.bind);
  int port = 0;
  s.read<int>("port", port, inRange(1, 65535), "[1, 65535]");
  r.port = static_cast<std::uint16_t>(port);
  s.read<int>("reply_deadline_ms", r.replyDeadlineMs, inRange(50, 60000), "[50, 60000]");
  s.read<int>("job", r.job, inRange(1, 32767), "[1, 32767]");
  s.read<int>("max_clients", r.maxClients, inRange(1, 64), "[1, 64]");
  readPerAddress(s, r.maxClients, r.maxClientsPerAddress);
  s.read<int>("stale_after_ms", r.staleAfterMs, inRange(100, 86400000), "[100, 86400000]");
  s.read<int>("idle_timeout_ms", r.idleTimeoutMs, inRange(0, 86400000), "[0, 86400000]");
  readAddressList(s, "allowed_clients", r.allowedClients, false);
  readAddressList(s, "control_clients", r.controlClients, false);

  std::string order = "best_score";
  s.read<std::string>("part_order", order, oneOf({"best_score", "by_label", "label_only", "random"}),
                      "one of: best_score, by_label, label_only, random");
  r.partOrder = order == "best_score" ? PartOrder::BestScore
                : order == "by_label" ? PartOrder::ByLabel
                : order == "random"   ? PartOrder::Random
                                      : PartOrder::LabelOnly;
  s.read<int>("label", r.label, inRange(0, 32767), "[0, 32767]");
  if (r.partOrder == PartOrder::LabelOnly && !s.get("label")) s.fail(s.node(), "label", "part_order label_only needs a label");
  s.read<bool>("reply_label", r.replyLabel);
  if (r.replyLabel && r.dialect == Dialect::Strict)
    s.fail(s.get("reply_label"), "reply_label", "the strict dialect's pose frame has no room for a label (paper 002's six values)");

  std::string deliver = "pose";
  s.read<std::string>("deliver", deliver, oneOf({"pose", "offset"}), "one of: pose, offset");
  r.delivery = *protocol::parseDelivery(deliver);  // oneOf() accepted exactly the names parseDelivery knows
  const YAML::Node frame = s.get("frame");
  if (frame && !frame.IsNull()) {
    Section f(s.file(), frame, s.join("frame"));
    f.require("name");
    f.read<std::string>("name", r.frameName, validFrameName, "1 to 32 printable characters");
    double x = 0, y = 0, z = 0, rz = 0, ry = 0, rx = 0;
    for (auto [key, out] : {std::pair{"x_mm", &x}, std::pair{"y_mm", &y}, std::pair{"z_mm", &z}})
      f.read<double>(key, *out, inRange(-1e6, 1e6), "[-1000000, 1000000]");
    for (auto [key, out] : {std::pair{"rz_deg", &rz}, std::pair{"ry_deg", &ry}, std::pair{"rx_deg", &rx}})
      f.read<double>(key, *out, inRange(-360.0, 360.0), "[-360, 360]");
    f.finish();
    r.baseFromUser = poseFromEulerZyxDeg(x, y, z, EulerZyxDeg{rz, ry, rx});
  }

  std::string abbRotation = "zyx";
  s.read<std::string>("abb_rotation", abbRotation, oneOf({"zyx", "quaternion"}), "one of: zyx, quaternion");
  r.abbRotation = *protocol::parseAbbRotation(abbRotation);  // oneOf() accepted exactly these names
  if (s.get("abb_rotation") && r.dialect != Dialect::Abb) s.fail(s.get("abb_rotation"), "abb_rotation", "only for dialect abb");
  // RAPID reads one reply of at most 80 characters: the quaternion reply takes up to 78 of them
  // and the label two more fields (protocol/robot_codec.hpp formatReply).
  if (r.replyLabel && r.abbRotation == AbbRotation::Quaternion)
    s.fail(s.get("reply_label"), "reply_label",
           "abb_rotation quaternion leaves no room for the label within RAPID's 80 characters; use abb_rotation zyx");

  const YAML::Node strict = s.get("strict");
  if (strict && !strict.IsNull()) {
    if (r.dialect != Dialect::Strict) s.fail(strict, "strict", "only for dialect strict");
    parseStrict(Section(s.file(), strict, s.join("strict")), r.strict);
  }
  s.finish();
}

// A job with `folder`: its job.yaml (config/job.hpp) gives the method, grasp height and
// reference; the cell entry may only name it, override the method and set the angle offset.
void parseJobFolder(Section& s, JobConfig& j) {
  namespace fs = std::filesystem;
  fs::path folder(j.folder);
  if (folder.is_relative()) folder = fs::path(s.file()).parent_path() / folder;
  j.folder = folder.lexically_normal().string();
  auto kind = jobKind(j.folder);
  if (!kind) s.fail(s.get("folder"), "folder", kind.error().message);
  if (*kind == "3d") {
    // A 3D job (config/job3d.hpp): the model and search come from its job.yaml; the cell
    // entry names it and may set limits. vgrd builds its locator at start (model.ply read there).
    for (const char* k : {"threshold", "min_area_px", "max_area_px", "part_height_mm", "reference", "method", "angle_offset_deg"})
      if (s.get(k)) s.fail(s.get(k), k, std::string("not for a 3D job (the folder's job.yaml says kind: 3d)"));
    auto job = loadJob3d(j.folder);
    if (!job) s.fail(s.get("folder"), "folder", job.error().message);
    if (!fs::exists(job->modelPath())) s.fail(s.get("folder"), "folder", job->modelPath() + ": the model cloud is missing");
    j.depth = true;
    j.method = "3d";
    parseLimits(Section(s.file(), s.get("limits"), s.join("limits")), j.limits);
    s.finish();
    return;
  }
  for (const char* k : {"threshold", "min_area_px", "max_area_px", "part_height_mm", "reference"})
    if (s.get(k)) s.fail(s.get(k), k, std::string("set in the job folder's job.yaml, not here (the job has a 'folder')"));
  parseLimits(Section(s.file(), s.get("limits"), s.join("limits")), j.limits);
  auto job = loadJob(j.folder);
  if (!job) s.fail(s.get("folder"), "folder", job.error().message);
  if (!fs::exists(job->templatePath())) s.fail(s.get("folder"), "folder", job->templatePath() + ": the template image is missing");
  j.method = job->method;
  s.read<std::string>("method", j.method);  // an override; checked when vgrd builds it
  s.read<double>("angle_offset_deg", j.angleOffsetDeg, inRange(-360.0, 360.0), "[-360, 360]");
  j.partHeightMm = job->partHeightMm;
  j.reference = {job->referenceXMm, job->referenceYMm, job->referenceZMm, job->referenceRzDeg};
  j.referenceGiven = job->referenceGiven;
  s.finish();
}

void parseJob(Section s, JobConfig& j) {
  s.require("id");
  s.read<int>("id", j.id, inRange(1, 32767), "[1, 32767]");
  s.read<std::string>("name", j.name);
  s.read<std::string>("folder", j.folder);
  if (!j.folder.empty()) {
    parseJobFolder(s, j);
    return;
  }
  s.read<std::string>("method", j.method, oneOf({"moments"}), "one of: moments (other methods need a job folder: 'folder')");
  s.read<int>("threshold", j.threshold, inRange(0, 255), "[0, 255]");
  s.read<double>("min_area_px", j.minAreaPx, [](const double& v) { return v > 0; }, "> 0");
  s.read<double>("max_area_px", j.maxAreaPx, [](const double& v) { return v > 0; }, "> 0");
  if (j.maxAreaPx <= j.minAreaPx) s.fail(s.get("max_area_px"), "max_area_px", "must be above min_area_px");
  s.read<double>("part_height_mm", j.partHeightMm, inRange(0.0, 1000.0), "[0, 1000]");
  s.read<double>("angle_offset_deg", j.angleOffsetDeg, inRange(-360.0, 360.0), "[-360, 360]");
  parseLimits(Section(s.file(), s.get("limits"), s.join("limits")), j.limits);
  j.referenceGiven = s.has("reference");
  Section ref(s.file(), s.get("reference"), s.join("reference"));
  ref.read<double>("x_mm", j.reference.x);
  ref.read<double>("y_mm", j.reference.y);
  ref.read<double>("z_mm", j.reference.z);
  ref.read<double>("rz_deg", j.reference.rzDeg, inRange(-360.0, 360.0), "[-360, 360]");
  ref.finish();
  s.finish();
}

void parseCalibration(Section s, CalibrationFilesConfig& c, const YAML::Node& node, const std::string& file, bool depthCamera) {
  if (!node || node.IsNull()) return;
  c.enabled = true;
  const std::string dir = std::filesystem::path(file).parent_path().string();
  auto readPath = [&](const char* key, std::string& out) {
    s.read<std::string>(key, out);
    if (out.empty()) s.fail(s.get(key), key, "expected a file path");
    if (std::filesystem::path(out).is_relative() && !dir.empty()) out = (std::filesystem::path(dir) / out).string();
  };
  if (s.has("check")) readPath("check", c.check);
  const YAML::Node drift = s.get("drift");
  if (drift && !drift.IsNull()) {
    Section d(s.file(), drift, s.join("drift"));
    c.drift.enabled = true;
    d.read<double>("threshold_mm", c.drift.thresholdMm, [](const double& v) { return v > 0 && v <= 100; }, "(0, 100]");
    d.read<int>("window", c.drift.window, inRange(1, 100), "[1, 100]");
    std::string onAlarm = "warn";
    d.read<std::string>("on_alarm", onAlarm, oneOf({"warn", "refuse"}), "one of: warn, refuse");
    c.drift.refuse = onAlarm == "refuse";
    d.finish();
    if (c.check.empty())
      s.fail(drift, "drift", "the drift monitor needs 'check': the file with the fiducial's stored position "
                             "(vgr calibrate verify --store, docs/calibration.md)");
  }
  if (depthCamera) {
    // A depth camera sends its intrinsics with every frame; a 3D pose needs no work plane.
    for (const char* key : {"intrinsics", "plane", "multiheight", "drift"})
      if (node.IsMap() && node[key])
        s.fail(node[key], key, "not for a depth camera (pixel_format Coord3D_C16): it sends its intrinsics with every "
                               "frame and a 3D pose needs no work plane; give 'handeye' alone (vgr calibrate handeye --cloud)");
    s.require("handeye");
    readPath("handeye", c.handeye);
  } else if (node.IsMap() && node["multiheight"]) {
    // Paper 001's multi-height map alone: it needs no camera model.
    for (const char* key : {"intrinsics", "handeye", "plane"})
      if (node[key]) s.fail(node[key], key, "give either 'multiheight' or 'intrinsics' + 'handeye' + 'plane', not both");
    readPath("multiheight", c.multiHeight);
  } else {
    for (auto [key, out] : {std::pair{"intrinsics", &c.intrinsics}, std::pair{"handeye", &c.handeye}, std::pair{"plane", &c.plane}}) {
      s.require(key);
      readPath(key, *out);
    }
  }
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
  s.read<std::string>("scene", c.scene, oneOf({"plate", "part", "multi"}), "one of: plate, part, multi");
  s.read<int>("levels", c.levels, inRange(2, 4), "[2, 4]");
  s.read<double>("angle_range_deg", c.angleRangeDeg, inRange(0.0, 180.0), "[0, 180]");
  s.read<int>("parts", c.parts, inRange(1, 16), "[1, 16]");
  s.read<int>("clutter", c.clutter, inRange(0, 64), "[0, 64]");
  s.read<bool>("still", c.still);
  Section shift(s.file(), s.get("camera_shift"), s.join("camera_shift"));
  shift.read<double>("x_mm", c.shiftXMm, inRange(-100.0, 100.0), "[-100, 100]");
  shift.read<double>("y_mm", c.shiftYMm, inRange(-100.0, 100.0), "[-100, 100]");
  shift.read<double>("z_mm", c.shiftZMm, inRange(-100.0, 100.0), "[-100, 100]");
  shift.read<double>("rz_deg", c.shiftRzDeg, inRange(-10.0, 10.0), "[-10, 10]");
  shift.finish();
  const YAML::Node fiducial = s.get("fiducial");
  if (fiducial && !fiducial.IsNull()) {
    Section f(s.file(), fiducial, s.join("fiducial"));
    for (const char* key : {"x_mm", "y_mm", "diameter_mm"}) f.require(key);
    f.read<double>("x_mm", c.fiducialXMm, inRange(-1e6, 1e6), "[-1000000, 1000000]");
    f.read<double>("y_mm", c.fiducialYMm, inRange(-1e6, 1e6), "[-1000000, 1000000]");
    f.read<double>("diameter_mm", c.fiducialDiameterMm, inRange(2.0, 100.0), "[2, 100]");
    f.finish();
  }
  if (const YAML::Node cls = s.get("classes"); cls && !cls.IsNull()) {
    if (!cls.IsSequence()) s.fail(cls, "classes", "expected a list of part class names");
    for (std::size_t i = 0; i < cls.size(); ++i) {
      if (!cls[i].IsScalar() || cls[i].Scalar().empty()) s.fail(cls[i], "classes", "expected a part class name");
      c.classes.push_back(cls[i].Scalar());
    }
    if (!c.classes.empty() && c.scene != "part") s.fail(cls, "classes", "needs scene: part");
  }
  s.finish();
}

void parseWeb(Section s, WebConfig& w) {
  if (!s.node() || s.node().IsNull()) return;
  w.enabled = true;
  s.read<bool>("enabled", w.enabled);
  s.read<std::string>("bind", w.bind, validIpAddress, "a numeric IP address");
  int port = w.port;
  s.read<int>("port", port, inRange(1, 65535), "[1, 65535]");
  w.port = static_cast<std::uint16_t>(port);
  s.read<bool>("page", w.page);
  s.read<bool>("actions", w.actions);
  const YAML::Node allowed = s.get("allowed_clients");
  if (allowed && !allowed.IsNull()) {
    if (!allowed.IsSequence()) s.fail(allowed, "allowed_clients", "expected a list of IP addresses");
    for (std::size_t i = 0; i < allowed.size(); ++i) {
      const std::string key = "allowed_clients[" + std::to_string(i) + "]";
      const std::string text = allowed[i].IsScalar() ? allowed[i].Scalar() : std::string("<non-scalar>");
      const std::string normal = allowed[i].IsScalar() ? normalIpAddress(text) : "";
      if (normal.empty()) s.fail(allowed[i], key, "expected a numeric IP address, got '" + text + "'");
      w.allowedClients.push_back(normal);
    }
  }
  if (w.actions && w.allowedClients.empty())
    s.fail(s.get("actions"), "actions", "operator actions need 'allowed_clients': the addresses allowed to trigger and switch jobs");
  if (w.actions && !w.page) s.fail(s.get("actions"), "actions", "operator actions are part of the page: not with 'page: false'");
  s.read<int>("live_max_width", w.liveMaxWidth, inRange(160, 8192), "[160, 8192]");
  s.finish();
}

void parseArchive(Section s, ArchiveConfig& a, const std::string& file) {
  if (!s.node() || s.node().IsNull()) return;
  a.enabled = true;
  s.read<bool>("enabled", a.enabled);
  s.read<std::string>("dir", a.dir);
  if (!a.dir.empty() && std::filesystem::path(a.dir).is_relative())
    a.dir = (std::filesystem::path(file).parent_path() / a.dir).lexically_normal().string();
  double quotaMb = static_cast<double>(a.quotaBytes) / 1e6;
  s.read<double>("quota_mb", quotaMb, inRange(1.0, 1e7), "[1, 10000000] (MB = 10^6 bytes)");
  a.quotaBytes = static_cast<std::uint64_t>(quotaMb * 1e6);
  s.read<int>("every_nth_good", a.everyNthGood, inRange(0, 1000000), "[0, 1000000] (0 = failed cycles only)");
  s.read<int>("queue", a.queue, inRange(1, 64), "[1, 64]");
  s.finish();
}

void parseMqtt(Section s, MqttConfig& m) {
  if (!s.node() || s.node().IsNull()) return;
  m.enabled = true;
  s.read<bool>("enabled", m.enabled);
  s.read<std::string>("host", m.host, [](const std::string& v) { return !v.empty(); }, "a host name or address");
  int port = m.port;
  s.read<int>("port", port, inRange(1, 65535), "[1, 65535]");
  m.port = static_cast<std::uint16_t>(port);
  s.read<std::string>("prefix", m.prefix,
                      [](const std::string& v) {
                        return !v.empty() && v.back() != '/' && v.find_first_of("#+") == std::string::npos;
                      },
                      "a non-empty topic level path without '#', '+' or a trailing '/'");
  s.read<std::string>("client_id", m.clientId);
  s.read<std::string>("username", m.username);
  s.read<std::string>("password", m.password);
  if (!m.password.empty() && m.username.empty()) s.fail(s.get("password"), "password", "needs a username");
  Section tls(s.file(), s.get("tls"), s.join("tls"));
  tls.read<std::string>("ca_file", m.tlsCaFile);
  tls.read<std::string>("cert_file", m.tlsCertFile);
  tls.read<std::string>("key_file", m.tlsKeyFile);
  tls.read<bool>("insecure", m.tlsInsecure);
  if (m.tlsCertFile.empty() != m.tlsKeyFile.empty()) tls.fail(tls.node(), "key_file", "cert_file and key_file go together");
  if (!m.tlsCertFile.empty() && m.tlsCaFile.empty()) tls.fail(tls.node(), "ca_file", "a client certificate needs ca_file");
  tls.finish();
  s.read<int>("keepalive_s", m.keepaliveS, inRange(5, 3600), "[5, 3600]");
  s.read<int>("queue", m.queueCapacity, inRange(1, 1000000), "[1, 1000000]");
  s.read<int>("reconnect_min_s", m.reconnectMinS, inRange(1, 3600), "[1, 3600]");
  s.read<int>("reconnect_max_s", m.reconnectMaxS, inRange(1, 3600), "[1, 3600]");
  if (m.reconnectMaxS < m.reconnectMinS)
    s.fail(s.get("reconnect_max_s"), "reconnect_max_s", "must not be below reconnect_min_s");
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
  cell.read<long long>("journal_max_bytes", c.journalMaxBytes, inRange<long long>(65536, 1LL << 40), "[65536, 2^40]");
  cell.read<int>("journal_files", c.journalFiles, inRange(1, 1000), "[1, 1000]");
  cell.read<int>("journal_sync_ms", c.journalSyncMs, inRange(-1, 3600000), "[-1, 3600000] (0: every record, -1: never)");
  cell.read<std::string>("log_level", c.logLevel,
                         oneOf({"trace", "debug", "info", "warn", "error", "critical", "off"}),
                         "one of: trace, debug, info, warn, error, critical, off");
  cell.read<int>("cycle_deadline_ms", c.cycleDeadlineMs, inRange(kMinCycleDeadlineMs, 60000),
                 fmt::format("[{}, 60000] ({} ms of it are kept for processing, the camera needs at least {} ms)",
                             kMinCycleDeadlineMs, kProcessingReserveMs, kMinCameraTimeMs));
  cell.finish();

  top.require("camera");
  parseCamera(Section(file, top.get("camera"), "camera"), c.camera);
  // The pinhole `model` maps pixels when there are no calibration files; with them it is
  // optional (vgrd, vgr locate and vgr eval map with the files: daemon/cell_mapping.hpp).
  if (!root["calibration"] || root["calibration"].IsNull()) top.require("model");
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
  // A job runs on the cell's one camera: a 3D job needs depth frames, a 2D method gray images.
  // Refused here (vgrd --check, vgr check, vgrd's start), naming the job and the camera.
  for (std::size_t k = 0; k < c.jobs.size(); ++k) {
    const JobConfig& j = c.jobs[k];
    if (j.depth == c.camera.depth()) continue;
    const std::string path = "jobs[" + std::to_string(k) + "]";
    const YAML::Node at = j.folder.empty() ? jobs[k] : jobs[k]["folder"];
    top.fail(at, path + (j.folder.empty() ? "" : ".folder"),
             j.depth ? fmt::format("job {} is a 3D job (kind: 3d) and camera '{}' is a 2D camera (pixel_format {}): a 3D "
                                   "job needs a depth camera (pixel_format Coord3D_C16)",
                                   j.id, c.camera.name, c.camera.pixelFormat)
                     : fmt::format("job {} is a 2D job (method {}) and camera '{}' is a depth camera (pixel_format "
                                   "Coord3D_C16): a 2D method needs gray images; a depth camera runs 3D jobs (kind: 3d)",
                                   j.id, j.method, c.camera.name));
  }
  // A robot's default job must be one of the cell's jobs (checked once the jobs are known).
  for (std::size_t i = 0; i < c.robots.size(); ++i) {
    const int job = c.robots[i].job;
    if (job != 0 && !ids.count(job))
      top.fail(robots[i]["job"], "robots[" + std::to_string(i) + "].job", "no job with id " + std::to_string(job) + " in jobs");
  }
  // Offsets are given from a job's taught reference: a job without one (the default 0 pose
  // is no taught pose) cannot serve a robot in offset mode (any job: JOB,<n> switches), nor
  // be limited in its offset.
  for (std::size_t k = 0; k < c.jobs.size(); ++k) {
    const JobConfig& j = c.jobs[k];
    if (j.referenceGiven) continue;
    const std::string path = "jobs[" + std::to_string(k) + "]";
    const YAML::Node at = j.folder.empty() ? jobs[k] : jobs[k]["folder"];
    const std::string where = j.depth           ? "a 3D job has no taught reference (docs/3d.md): deliver poses"
                              : j.folder.empty() ? "give `reference: {x_mm, y_mm, z_mm, rz_deg}` here"
                                                 : "give `reference:` in " + j.folder + "/job.yaml";
    for (std::size_t i = 0; i < c.robots.size(); ++i)
      if (c.robots[i].delivery == Delivery::Offset)
        top.fail(at, path + (j.folder.empty() ? ".reference" : ".folder"),
                 fmt::format("robots[{}] ('{}') delivers offsets from the job's taught reference, and job {} has none: {}", i,
                             c.robots[i].name, j.id, where));
    if (!j.limits.offset.empty())
      top.fail(jobs[k]["limits"]["offset"], path + ".limits.offset",
               fmt::format("offset limits are relative to the job's taught reference, and job {} has none: {}", j.id, where));
  }

  parseSim(Section(file, top.get("sim"), "sim"), c.sim);
  {
    const YAML::Node cal = top.get("calibration");
    parseCalibration(Section(file, cal, "calibration"), c.calibration, cal, file, c.camera.depth());
  }
  parseWeb(Section(file, top.get("web"), "web"), c.web);
  if (c.web.enabled && ports.contains(c.web.port))  // vgrd binds it next to the robots' and Modbus ports
    top.fail(top.get("web")["port"], "web.port", "port already used by another endpoint");
  parseMqtt(Section(file, top.get("mqtt"), "mqtt"), c.mqtt);
  parseArchive(Section(file, top.get("archive"), "archive"), c.archive, file);
  top.finish();
  return c;
}

}  // namespace

const char* triggerModeName(TriggerMode m) {
  switch (m) {
    case TriggerMode::Software: return "software";
    case TriggerMode::Hardware: return "hardware";
    case TriggerMode::FreeRun: return "free_run";
  }
  return "software";
}

const JobConfig* CellConfig::findJob(int id) const {
  for (const auto& j : jobs)
    if (j.id == id) return &j;
  return nullptr;
}

Result<CellConfig> parseCellConfig(const std::string& text, const std::string& sourceName) {
  try {
    failOnInvalidUtf8(sourceName, text);
    return parse(YAML::Load(text), sourceName);
  } catch (const SectionError& e) {
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

Result<std::string> writeSimCell(const std::string& dir, const std::string& yamlText) {
  namespace fs = std::filesystem;
  std::error_code ec;
  fs::create_directories(fs::path(dir) / "sim-calib", ec);
  if (ec) return fail(Status::BadArgument, dir + ": " + ec.message());
  const std::pair<std::string, const std::string*> files[] = {
      {"sim-cell.yaml", &yamlText},
      {"sim-calib/intrinsics.yaml", &embeddedSimCalibIntrinsics()},
      {"sim-calib/handeye.yaml", &embeddedSimCalibHandEye()},
      {"sim-calib/plane.yaml", &embeddedSimCalibPlane()}};
  for (const auto& [name, text] : files) {
    std::ofstream out(fs::path(dir) / name);
    out << *text;
    if (!out) return fail(Status::BadArgument, (fs::path(dir) / name).string() + ": cannot write");
  }
  return (fs::path(dir) / "sim-cell.yaml").string();
}

}  // namespace vgr::config
