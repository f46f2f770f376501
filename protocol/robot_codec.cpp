#include "protocol/robot_codec.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <system_error>
#include <vector>

namespace vgr::protocol {
namespace binary {
void appendInt32(std::string& out, std::int32_t v);
}  // namespace binary
namespace {

bool isTerminator(char c) { return c == '#' || c == '\r' || c == '\n'; }
bool isBlank(char c) { return c == ' ' || c == '\t'; }

std::string_view trim(std::string_view s) {
  while (!s.empty() && isBlank(s.front())) s.remove_prefix(1);
  while (!s.empty() && isBlank(s.back())) s.remove_suffix(1);
  return s;
}

bool isBlankOnly(std::string_view s) { return trim(s).empty(); }

// Appends v in fixed notation with `decimals` digits, locale-independent (to_chars), never
// "-0.000". The caller guarantees v is finite and bounded, so the result is short.
void appendFixed(std::string& out, double v, int decimals) {
  std::array<char, 64> buf{};
  auto [end, ec] = std::to_chars(buf.data(), buf.data() + buf.size(), v, std::chars_format::fixed, decimals);
  if (ec != std::errc{}) {  // cannot happen for bounded finite values; keep the wire valid anyway
    end = std::to_chars(buf.data(), buf.data() + buf.size(), 0.0, std::chars_format::fixed, decimals).ptr;
  }
  std::string_view text(buf.data(), static_cast<std::size_t>(end - buf.data()));
  if (!text.empty() && text.front() == '-' && text.find_first_not_of("-0.") == std::string_view::npos) {
    text.remove_prefix(1);  // "-0.000" -> "0.000"
  }
  out.append(text);
}

void appendInt(std::string& out, long long v) {
  std::array<char, 24> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v);
  out.append(buf.data(), res.ptr);
}

bool finite(const Pose& p) {
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && std::isfinite(p.qw) && std::isfinite(p.qx) &&
         std::isfinite(p.qy) && std::isfinite(p.qz);
}

// True when the pose can be written: finite, positions within kMaxAbsPositionMm and a
// quaternion that can be normalised (a zero quaternion is no rotation at all).
bool representable(const Pose& p) {
  if (!finite(p)) return false;
  if (std::abs(p.x) > kMaxAbsPositionMm || std::abs(p.y) > kMaxAbsPositionMm || std::abs(p.z) > kMaxAbsPositionMm) {
    return false;
  }
  const double n2 = p.qw * p.qw + p.qx * p.qx + p.qy * p.qy + p.qz * p.qz;
  return std::isfinite(n2) && n2 > 1e-12;
}

std::string formatUr(int status, std::uint32_t cycle, const Pose& p, bool zeroPose) {
  Vec3 rv{};
  if (!zeroPose) rv = toRotationVector(p);
  const double values[6] = {
      zeroPose ? 0.0 : p.x / 1000.0, zeroPose ? 0.0 : p.y / 1000.0, zeroPose ? 0.0 : p.z / 1000.0, rv.x, rv.y, rv.z};
  std::string out;
  out.reserve(96);
  out.push_back('(');
  appendInt(out, status);
  out.push_back(',');
  appendInt(out, cycle);
  for (double v : values) {
    out.push_back(',');
    appendFixed(out, v, 6);
  }
  out.push_back(')');
  return out;
}

std::string formatAbb(int status, std::uint32_t cycle, const Pose& p, bool zeroPose) {
  EulerZyxDeg e{};
  if (!zeroPose) e = toEulerZyxDeg(p);
  const double values[6] = {zeroPose ? 0.0 : p.x, zeroPose ? 0.0 : p.y, zeroPose ? 0.0 : p.z, e.rz, e.ry, e.rx};
  std::string out;
  out.reserve(kAbbMaxReplyChars);
  appendInt(out, status);
  out.push_back(',');
  appendInt(out, cycle);
  for (double v : values) {
    out.push_back(',');
    appendFixed(out, v, 3);
  }
  return out;
}

// The RAPID orient of a pose: q1..q4 = w, x, y, z, unit, q1 >= 0 (core/pose keeps w >= 0).
std::string formatAbbQuaternion(int status, std::uint32_t cycle, const Pose& p, bool zeroPose) {
  double q[4] = {1.0, 0.0, 0.0, 0.0};
  if (!zeroPose) {
    const double n = std::sqrt(p.qw * p.qw + p.qx * p.qx + p.qy * p.qy + p.qz * p.qz);
    const double sign = p.qw < 0 ? -1.0 : 1.0;
    q[0] = sign * p.qw / n, q[1] = sign * p.qx / n, q[2] = sign * p.qy / n, q[3] = sign * p.qz / n;
  }
  const double pos[3] = {zeroPose ? 0.0 : p.x, zeroPose ? 0.0 : p.y, zeroPose ? 0.0 : p.z};
  std::string out;
  out.reserve(kAbbMaxReplyChars);
  appendInt(out, status);
  out.push_back(',');
  appendInt(out, cycle);
  for (double v : pos) {
    out.push_back(',');
    appendFixed(out, v, 3);
  }
  for (double v : q) {
    out.push_back(',');
    appendFixed(out, v, 5);
  }
  return out;
}

// Fixed-width, sign-padded: '+' or '-', then |v| with `decimals` decimals, zero-padded on
// the left to `intDigits` integer digits. A value that rounds to zero gets '+'. The caller
// guarantees |v| fits (it is bounded by kMaxAbsPositionMm or 180 degrees).
void appendSignPadded(std::string& out, double v, int intDigits, int decimals) {
  std::array<char, 64> buf{};
  const double mag = std::abs(v);
  auto res = std::to_chars(buf.data(), buf.data() + buf.size(), mag, std::chars_format::fixed, decimals);
  if (res.ec != std::errc{}) res = std::to_chars(buf.data(), buf.data() + buf.size(), 0.0, std::chars_format::fixed, decimals);
  const std::string_view text(buf.data(), static_cast<std::size_t>(res.ptr - buf.data()));
  const bool zero = text.find_first_not_of("0.") == std::string_view::npos;
  out.push_back(v < 0 && !zero ? '-' : '+');
  const std::size_t width = static_cast<std::size_t>(intDigits + 1 + decimals);
  if (text.size() < width) out.append(width - text.size(), '0');
  out.append(text);
}

// Integer field: optional sign ('+'/'-') and `digits` zero-padded digits.
void appendIntPadded(std::string& out, long long v, int digits, bool withSign) {
  if (withSign) out.push_back(v < 0 ? '-' : '+');
  std::array<char, 24> buf{};
  const auto res = std::to_chars(buf.data(), buf.data() + buf.size(), v < 0 ? -v : v);
  const std::string_view text(buf.data(), static_cast<std::size_t>(res.ptr - buf.data()));
  if (text.size() < static_cast<std::size_t>(digits)) out.append(static_cast<std::size_t>(digits) - text.size(), '0');
  out.append(text);
}

constexpr long long kFanucMaxCycle = 9999999;  // 7 digits; cycle ids stay below 2^23

std::string formatFanuc(int status, std::uint32_t cycle, const Pose& p, bool zeroPose) {
  EulerZyxDeg e{};
  if (!zeroPose) e = toEulerZyxDeg(p);
  std::string out;
  out.reserve(kFanucReplyChars);
  appendIntPadded(out, status, 4, true);
  out.push_back(',');
  appendIntPadded(out, std::min<long long>(cycle, kFanucMaxCycle), 7, false);
  const double pos[3] = {zeroPose ? 0.0 : p.x, zeroPose ? 0.0 : p.y, zeroPose ? 0.0 : p.z};
  for (double v : pos) {
    out.push_back(',');
    appendSignPadded(out, v, 5, 3);
  }
  const double wpr[3] = {e.rx, e.ry, e.rz};  // W = rx, P = ry, R = rz
  for (double v : wpr) {
    out.push_back(',');
    appendSignPadded(out, v, 3, 3);
  }
  out.append("\r\n");
  return out;
}

std::int32_t scaled(double v) { return static_cast<std::int32_t>(std::llround(v * 1000.0)); }

std::string formatBinary(int status, std::uint32_t cycle, const Pose& p, bool zeroPose) {
  EulerZyxDeg e{};
  if (!zeroPose) e = toEulerZyxDeg(p);
  std::string out;
  out.reserve(binary::kReplyBytes);
  binary::appendInt32(out, static_cast<std::int32_t>(binary::kReplyMagic));
  binary::appendInt32(out, static_cast<std::int32_t>(binary::kReplyBytes));
  binary::appendInt32(out, status);
  binary::appendInt32(out, static_cast<std::int32_t>(cycle & 0x7FFFFFFFu));
  const double values[6] = {p.x, p.y, p.z, e.rx, e.ry, e.rz};
  for (double v : values) binary::appendInt32(out, zeroPose ? 0 : scaled(v));
  return out;
}

bool anyNonFinite(const double* v, std::size_t n) {
  for (std::size_t i = 0; i < n; ++i) {
    if (!std::isfinite(v[i])) return true;
  }
  return false;
}

}  // namespace

std::optional<Dialect> parseDialect(std::string_view text) {
  if (text == "ur") return Dialect::Ur;
  if (text == "abb") return Dialect::Abb;
  if (text == "fanuc") return Dialect::Fanuc;
  if (text == "binary") return Dialect::Binary;
  if (text == "strict") return Dialect::Strict;
  return std::nullopt;
}

std::string_view dialectName(Dialect dialect) {
  switch (dialect) {
    case Dialect::Ur:
      return "ur";
    case Dialect::Abb:
      return "abb";
    case Dialect::Fanuc:
      return "fanuc";
    case Dialect::Binary:
      return "binary";
    case Dialect::Strict:
      return "strict";
  }
  return "?";
}

std::optional<AbbRotation> parseAbbRotation(std::string_view text) {
  if (text == "zyx") return AbbRotation::EulerZyx;
  if (text == "quaternion") return AbbRotation::Quaternion;
  return std::nullopt;
}

std::string_view abbRotationName(AbbRotation rotation) {
  return rotation == AbbRotation::Quaternion ? "quaternion" : "zyx";
}
std::optional<Delivery> parseDelivery(std::string_view text) {
  if (text == "pose") return Delivery::Pose;
  if (text == "offset") return Delivery::Offset;
  return std::nullopt;
}

std::string_view deliveryName(Delivery delivery) { return delivery == Delivery::Offset ? "offset" : "pose"; }

// ---------------------------------------------------------------------------------------
// RequestSplitter

RequestSplitter::RequestSplitter(std::size_t maxRequestBytes) : maxRequestBytes_(maxRequestBytes) {}

void RequestSplitter::append(std::string_view bytes) {
  if (discarding_) {
    std::size_t i = 0;
    while (i < bytes.size() && !isTerminator(bytes[i])) ++i;
    if (i == bytes.size()) return;  // still inside the over-long request
    discarding_ = false;
    bytes.remove_prefix(i + 1);
  }
  // Compact before growing so the buffer never keeps consumed requests.
  if (scanPos_ > 0) {
    buffer_.erase(0, scanPos_);
    scanPos_ = 0;
  }
  buffer_.append(bytes);
}

std::optional<Result<std::string>> RequestSplitter::next() {
  for (;;) {
    const std::string_view rest = std::string_view(buffer_).substr(scanPos_);
    std::size_t end = 0;
    while (end < rest.size() && !isTerminator(rest[end])) ++end;

    if (end == rest.size()) {  // no terminator buffered
      if (rest.size() <= maxRequestBytes_) return std::nullopt;
      // Over-long and still open: report once, drop it and skip to the next terminator.
      buffer_.clear();
      scanPos_ = 0;
      discarding_ = true;
      return Result<std::string>(fail(Status::UnknownCommand, "request too long"));
    }

    const std::string_view line = rest.substr(0, end);
    scanPos_ += end + 1;
    if (line.size() > maxRequestBytes_) return Result<std::string>(fail(Status::UnknownCommand, "request too long"));
    if (isBlankOnly(line)) continue;  // CRLF, "##", stray spaces: not a request
    return Result<std::string>(std::string(line));
  }
}

// ---------------------------------------------------------------------------------------
// Requests

namespace {

// Job field: decimal, no sign, [kMinJob, kMaxJob].
Result<int> parseJob(std::string_view jobText) {
  if (jobText.empty()) return fail(Status::BadArgument, "missing job number");
  int job = 0;
  const auto [ptr, ec] = std::from_chars(jobText.data(), jobText.data() + jobText.size(), job);
  if (ec != std::errc{} || ptr != jobText.data() + jobText.size() || jobText.front() == '-') {
    return fail(Status::BadArgument, "job is not a number");
  }
  if (job < kMinJob || job > kMaxJob) return fail(Status::BadArgument, "job out of range [1, 32767]");
  return job;
}

// Comma-separated finite numbers (blanks around each allowed, a leading '+' too).
Result<std::vector<double>> parseNumbers(std::string_view text) {
  std::vector<double> out;
  for (;;) {
    const std::size_t comma = text.find(',');
    std::string_view field = trim(text.substr(0, comma));
    if (!field.empty() && field.front() == '+') field.remove_prefix(1);
    double v = 0;
    const auto [ptr, ec] = std::from_chars(field.data(), field.data() + field.size(), v);
    if (field.empty() || ec != std::errc{} || ptr != field.data() + field.size())
      return fail(Status::BadArgument, "pose field " + std::to_string(out.size() + 1) + " is not a number");
    if (!std::isfinite(v)) return fail(Status::BadArgument, "pose field " + std::to_string(out.size() + 1) + " is not finite");
    out.push_back(v);
    if (out.size() > 16) return fail(Status::BadArgument, "pose has too many fields");
    if (comma == std::string_view::npos) break;
    text.remove_prefix(comma + 1);
  }
  return out;
}

// `text` without `open` at its start and `close` at its end (after trimming), when it has both.
bool unwrap(std::string_view& text, std::string_view open, std::string_view close) {
  const std::string_view t = trim(text);
  if (t.size() < open.size() + close.size() || t.substr(0, open.size()) != open || t.substr(t.size() - close.size()) != close)
    return false;
  text = t.substr(open.size(), t.size() - open.size() - close.size());
  return true;
}

Result<void> checkPosition(double x, double y, double z) {
  if (std::abs(x) > kMaxAbsPositionMm || std::abs(y) > kMaxAbsPositionMm || std::abs(z) > kMaxAbsPositionMm)
    return fail(Status::BadArgument, "pose position beyond +-99999.999 mm");
  return {};
}

Result<Pose> poseFromQuaternionChecked(double x, double y, double z, double qw, double qx, double qy, double qz) {
  const double n = std::sqrt(qw * qw + qx * qx + qy * qy + qz * qz);
  if (!(std::abs(n - 1.0) <= kMaxQuaternionNormError))
    return fail(Status::BadArgument, "pose quaternion has norm " + std::to_string(n) + ", not 1: not a rotation");
  if (auto ok = checkPosition(x, y, z); !ok) return std::unexpected(ok.error());
  return poseFromQuaternion(x, y, z, qw, qx, qy, qz);
}

Result<Pose> poseFromEulerChecked(double x, double y, double z, double a, double b, double c, bool zyxOrder) {
  for (double v : {a, b, c})
    if (std::abs(v) > 360.0) return fail(Status::BadArgument, "pose angle beyond +-360 degrees: not a rotation a controller sends");
  if (auto ok = checkPosition(x, y, z); !ok) return std::unexpected(ok.error());
  // abb: rz, ry, rx (OrientZYX order); fanuc: W, P, R = rx, ry, rz.
  return poseFromEulerZyxDeg(x, y, z, zyxOrder ? EulerZyxDeg{a, b, c} : EulerZyxDeg{c, b, a});
}

Result<Pose> poseFromMetresRotationVector(const std::vector<double>& v) {
  const double angle = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5]);
  if (angle > 2 * M_PI + 1e-9)
    return fail(Status::BadArgument, "pose rotation vector longer than 2 pi: not a rotation a controller sends");
  const double x = v[0] * 1000.0, y = v[1] * 1000.0, z = v[2] * 1000.0;
  if (auto ok = checkPosition(x, y, z); !ok) return std::unexpected(ok.error());
  return poseFromRotationVector(x, y, z, Vec3{v[3], v[4], v[5]});
}

}  // namespace

Result<Pose> parsePose(Dialect dialect, std::string_view text) {
  switch (dialect) {
    case Dialect::Ur:
    case Dialect::Strict: {
      std::string_view body = text;
      unwrap(body, "p[", "]");  // URScript's printed pose
      auto v = parseNumbers(body);
      if (!v) return std::unexpected(v.error());
      if (v->size() != 6) return fail(Status::BadArgument, "pose needs 6 numbers (x, y, z in m, rx, ry, rz in rad), got " + std::to_string(v->size()));
      return poseFromMetresRotationVector(*v);
    }
    case Dialect::Abb: {
      std::string_view body = text;
      if (unwrap(body, "[[", "]]")) {  // RAPID ValToStr of a pose: [[x,y,z],[q1,q2,q3,q4]]
        const std::size_t mid = body.find("],[");
        if (mid == std::string_view::npos) return fail(Status::BadArgument, "pose: expected [[x,y,z],[q1,q2,q3,q4]]");
        auto pos = parseNumbers(body.substr(0, mid));
        auto rot = parseNumbers(body.substr(mid + 3));
        if (!pos) return std::unexpected(pos.error());
        if (!rot) return std::unexpected(rot.error());
        if (pos->size() != 3 || rot->size() != 4) return fail(Status::BadArgument, "pose: expected [[x,y,z],[q1,q2,q3,q4]]");
        const auto& p = *pos;
        const auto& q = *rot;
        return poseFromQuaternionChecked(p[0], p[1], p[2], q[0], q[1], q[2], q[3]);
      }
      auto v = parseNumbers(body);
      if (!v) return std::unexpected(v.error());
      const auto& n = *v;
      if (n.size() == 7) return poseFromQuaternionChecked(n[0], n[1], n[2], n[3], n[4], n[5], n[6]);
      if (n.size() == 6) return poseFromEulerChecked(n[0], n[1], n[2], n[3], n[4], n[5], true);
      return fail(Status::BadArgument, "pose needs 7 numbers (x, y, z mm, q1..q4) or 6 (x, y, z mm, rz, ry, rx deg), got " +
                                           std::to_string(n.size()));
    }
    case Dialect::Fanuc: {
      auto v = parseNumbers(text);
      if (!v) return std::unexpected(v.error());
      const auto& n = *v;
      if (n.size() != 6) return fail(Status::BadArgument, "pose needs 6 numbers (x, y, z mm, w, p, r deg), got " + std::to_string(n.size()));
      return poseFromEulerChecked(n[0], n[1], n[2], n[3], n[4], n[5], false);
    }
    case Dialect::Binary:
      break;
  }
  return fail(Status::BadArgument, "the binary dialect has no text pose");
}

Result<Pose> parseStrictPoseFrame(std::string_view text) {
  std::string_view body = text;
  if (!unwrap(body, "(", ")") && !unwrap(body, "p[", "]"))
    return fail(Status::BadArgument, "pose frame: expected (x,y,z,rx,ry,rz) or p[x, y, z, rx, ry, rz]");
  auto v = parseNumbers(body);
  if (!v) return std::unexpected(v.error());
  if (v->size() != 6) return fail(Status::BadArgument, "pose frame needs 6 numbers, got " + std::to_string(v->size()));
  return poseFromMetresRotationVector(*v);
}

Result<RobotRequest> parseRequest(std::string_view line, Dialect dialect) {
  // Command, job and the rest (a pose holds commas of its own).
  const std::size_t c1 = line.find(',');
  const std::string_view command = trim(line.substr(0, c1));
  const bool hasJob = c1 != std::string_view::npos;
  std::string_view jobText, rest;
  bool hasRest = false;
  if (hasJob) {
    const std::string_view afterCommand = line.substr(c1 + 1);
    const std::size_t c2 = afterCommand.find(',');
    jobText = trim(afterCommand.substr(0, c2));
    if (c2 != std::string_view::npos) {
      rest = afterCommand.substr(c2 + 1);
      hasRest = true;
    }
  }

  RobotRequest req;
  if (command == "JOB") {
    if (!hasJob) return fail(Status::BadArgument, "missing job number");
    if (hasRest) return fail(Status::BadArgument, "too many fields");
    auto job = parseJob(jobText);
    if (!job) return std::unexpected(job.error());
    req.command = Command::Job;
    req.job = *job;
    return req;
  }
  if (command != "TRIG" && command != "GET") return fail(Status::UnknownCommand, "unknown command");
  req.command = command == "TRIG" ? Command::Trigger : Command::Get;
  if (!hasJob) return req;  // "GET" / "TRIG": the robot's current job
  auto job = parseJob(jobText);
  if (!job) return std::unexpected(job.error());
  req.job = *job;
  if (!hasRest) return req;
  if (req.command == Command::Get && trim(rest) == "LAST") {
    req.last = true;
    return req;
  }
  // A snapshot: the flange pose at the image, in the dialect's notation.
  auto pose = parsePose(dialect, rest);
  if (!pose) {
    if (req.command == Command::Get && rest.find(',') == std::string_view::npos && rest.find('[') == std::string_view::npos)
      return fail(Status::BadArgument, "unknown option (expected LAST or a flange pose)");
    return std::unexpected(pose.error());
  }
  req.command = Command::Trigger;
  req.flange = *pose;
  return req;
}

// ---------------------------------------------------------------------------------------
// Binary frames

namespace binary {

void appendInt32(std::string& out, std::int32_t v) {
  const auto u = static_cast<std::uint32_t>(v);
  out.push_back(static_cast<char>((u >> 24) & 0xFF));
  out.push_back(static_cast<char>((u >> 16) & 0xFF));
  out.push_back(static_cast<char>((u >> 8) & 0xFF));
  out.push_back(static_cast<char>(u & 0xFF));
}

std::int32_t readInt32(std::string_view frame, std::size_t at) {
  std::uint32_t u = 0;
  for (std::size_t i = 0; i < 4; ++i) u = (u << 8) | static_cast<unsigned char>(frame[at + i]);
  return static_cast<std::int32_t>(u);
}

std::string encodeRequest(std::int32_t command, std::int32_t job, const std::optional<Pose>& flange) {
  std::string out;
  out.reserve(kPoseRequestBytes);
  appendInt32(out, static_cast<std::int32_t>(kRequestMagic));
  appendInt32(out, static_cast<std::int32_t>(flange ? kPoseRequestBytes : kRequestBytes));
  appendInt32(out, command);
  appendInt32(out, job);
  if (flange) {
    const EulerZyxDeg e = toEulerZyxDeg(*flange);
    const double values[6] = {flange->x, flange->y, flange->z, e.rx, e.ry, e.rz};
    for (double v : values) appendInt32(out, static_cast<std::int32_t>(std::llround(v * 1000.0)));
  }
  return out;
}

}  // namespace binary

RequestDecoder::RequestDecoder(Dialect dialect) : dialect_(dialect) {}

void RequestDecoder::append(std::string_view bytes) {
  if (dialect_ != Dialect::Binary) {
    text_.append(bytes);
    return;
  }
  bin_.append(bytes);
}

std::size_t RequestDecoder::partial() const {
  if (dialect_ != Dialect::Binary) return text_.buffered() + (text_.discarding() ? 1 : 0);
  return bin_.size();
}

std::optional<Result<RobotRequest>> RequestDecoder::next() {
  if (dialect_ != Dialect::Binary) {
    std::optional<Result<std::string>> line = text_.next();
    if (!line) return std::nullopt;
    if (!*line) return Result<RobotRequest>(std::unexpected(std::move(line->error())));
    return parseRequest(**line, dialect_);
  }

  std::string magic;
  binary::appendInt32(magic, static_cast<std::int32_t>(binary::kRequestMagic));
  // Garbage before a magic: drop it, report once per run.
  const std::size_t at = bin_.find(magic);
  if (at != 0) {
    // Keep a tail that may be the start of a magic split across reads.
    const std::size_t drop = at == std::string::npos ? (bin_.size() > 3 ? bin_.size() - 3 : 0) : at;
    if (drop > 0) {
      bin_.erase(0, drop);
      if (!inGarbage_) {
        inGarbage_ = true;
        return Result<RobotRequest>(fail(Status::UnknownCommand, "binary request without the 'VGRQ' magic"));
      }
    }
    if (at == std::string::npos) return std::nullopt;
  }
  if (bin_.size() < 8) return std::nullopt;
  const std::int32_t length = binary::readInt32(bin_, 4);
  if (length != static_cast<std::int32_t>(binary::kRequestBytes) &&
      length != static_cast<std::int32_t>(binary::kPoseRequestBytes)) {
    // The frame boundary is unknown: skip only the magic and look for the next one.
    // One bad frame, one error: what follows up to the next magic is not reported again.
    bin_.erase(0, 4);
    inGarbage_ = true;
    return Result<RobotRequest>(fail(Status::BadArgument, "binary request length is not 16 or 40"));
  }
  const auto frameBytes = static_cast<std::size_t>(length);
  if (bin_.size() < frameBytes) return std::nullopt;
  inGarbage_ = false;

  const std::string_view frame(bin_.data(), frameBytes);
  const std::int32_t command = binary::readInt32(frame, 8);
  const std::int32_t job = binary::readInt32(frame, 12);
  std::optional<Pose> flange;
  if (frameBytes == binary::kPoseRequestBytes) {
    double v[6];
    for (std::size_t i = 0; i < 6; ++i) v[i] = binary::readInt32(frame, 16 + 4 * i) / 1000.0;  // mm, degrees
    flange = poseFromEulerZyxDeg(v[0], v[1], v[2], EulerZyxDeg{v[5], v[4], v[3]});
    const bool angles = std::abs(v[3]) <= 360.0 && std::abs(v[4]) <= 360.0 && std::abs(v[5]) <= 360.0;
    const bool position = std::abs(v[0]) <= kMaxAbsPositionMm && std::abs(v[1]) <= kMaxAbsPositionMm &&
                          std::abs(v[2]) <= kMaxAbsPositionMm;
    bin_.erase(0, frameBytes);
    if (command != binary::kCmdGet && command != binary::kCmdTrigger)
      return Result<RobotRequest>(fail(Status::BadArgument, "a flange pose goes with GET or TRIG only"));
    if (!angles) return Result<RobotRequest>(fail(Status::BadArgument, "pose angle beyond +-360 degrees: not a rotation a controller sends"));
    if (!position) return Result<RobotRequest>(fail(Status::BadArgument, "pose position beyond +-99999.999 mm"));
    if (job < kMinJob || job > kMaxJob) return Result<RobotRequest>(fail(Status::BadArgument, "a snapshot needs a job in [1, 32767]"));
    RobotRequest req;
    req.command = Command::Trigger;
    req.job = job;
    req.flange = flange;
    return Result<RobotRequest>(req);
  }
  bin_.erase(0, frameBytes);

  RobotRequest req;
  switch (command) {
    case binary::kCmdGet:
    case binary::kCmdGetLast:
      req.command = Command::Get;
      req.last = command == binary::kCmdGetLast;
      if (job == 0) {
        if (req.last) return Result<RobotRequest>(fail(Status::BadArgument, "GET LAST needs a job"));
        return Result<RobotRequest>(req);
      }
      break;
    case binary::kCmdJob:
      req.command = Command::Job;
      break;
    case binary::kCmdTrigger:
      req.command = Command::Trigger;
      if (job == 0) return Result<RobotRequest>(req);
      break;
    default:
      return Result<RobotRequest>(fail(Status::UnknownCommand, "unknown binary command"));
  }
  if (job < kMinJob || job > kMaxJob) return Result<RobotRequest>(fail(Status::BadArgument, "job out of range [1, 32767]"));
  req.job = job;
  return Result<RobotRequest>(req);
}

// ---------------------------------------------------------------------------------------
// Replies

namespace {

// The label fields of a withLabel reply (robot_codec.hpp), appended to a text reply.
void appendLabelText(std::string& out, int label, double confidence) {
  out.push_back(',');
  appendInt(out, label);
  out.push_back(',');
  appendFixed(out, confidence, 3);
}

}  // namespace

std::string formatReply(Dialect dialect, const RobotReply& reply, bool withLabel, AbbRotation abbRotation) {
  int status = statusCode(reply.status);
  bool zeroPose = reply.status != Status::Ok;
  if (!zeroPose && !representable(reply.pose)) {
    status = statusCode(Status::Internal);
    zeroPose = true;
  }
  // A label the wire cannot carry is never cut short: the reply becomes an error.
  if (!zeroPose && withLabel &&
      (reply.label < 0 || reply.label > kMaxReplyLabel || !(reply.confidence >= 0 && reply.confidence <= 1))) {
    status = statusCode(Status::Internal);
    zeroPose = true;
  }
  // The conversions themselves must not produce NaN either (they cannot for a normalisable
  // quaternion, but the wire promise is absolute).
  if (!zeroPose) {
    const EulerZyxDeg e = toEulerZyxDeg(reply.pose);
    const Vec3 rv = toRotationVector(reply.pose);
    const double all[6] = {e.rz, e.ry, e.rx, rv.x, rv.y, rv.z};
    if (anyNonFinite(all, 6)) {
      status = statusCode(Status::Internal);
      zeroPose = true;
    }
  }

  const int label = zeroPose ? 0 : reply.label;
  const double confidence = zeroPose ? 0.0 : reply.confidence;
  switch (dialect) {
    case Dialect::Strict:
      return formatUr(status, reply.cycleId, reply.pose, zeroPose);
    case Dialect::Ur: {
      std::string out = formatUr(status, reply.cycleId, reply.pose, zeroPose);
      if (withLabel) {
        out.pop_back();  // ')'
        appendLabelText(out, label, confidence);
        out.push_back(')');
      }
      return out;
    }
    case Dialect::Fanuc: {
      std::string out = formatFanuc(status, reply.cycleId, reply.pose, zeroPose);
      if (withLabel) {
        out.resize(out.size() - 2);  // CR LF
        out.push_back(',');
        appendIntPadded(out, label, 3, false);
        out.push_back(',');
        appendFixed(out, confidence, 3);
        out.append("\r\n");
      }
      return out;
    }
    case Dialect::Binary: {
      std::string out = formatBinary(status, reply.cycleId, reply.pose, zeroPose);
      if (withLabel) {
        binary::appendInt32(out, label);
        binary::appendInt32(out, static_cast<std::int32_t>(std::lround(confidence * 1000.0)));
        // The length field (bytes 4-7) says 48.
        std::string len;
        binary::appendInt32(len, static_cast<std::int32_t>(binary::kLabelReplyBytes));
        out.replace(4, 4, len);
      }
      return out;
    }
    case Dialect::Abb: {
      const auto format = abbRotation == AbbRotation::Quaternion ? &formatAbbQuaternion : &formatAbb;
      std::string out = format(status, reply.cycleId, reply.pose, zeroPose);
      if (withLabel) appendLabelText(out, label, confidence);
      // Z-Y-X: unreachable for the daemon's cycle ids (< 2^23: Ok replies are at most 68
      // characters, 78 with the label). Quaternion: at most 78 characters without the label,
      // 88 with it, so a far pose with a label would not fit: config/ refuses abb_rotation
      // quaternion together with reply_label, and this keeps any caller from sending RAPID a
      // truncated reply.
      if (out.size() > kAbbMaxReplyChars) {
        out = format(statusCode(Status::Internal), reply.cycleId, reply.pose, true);
        if (withLabel) appendLabelText(out, 0, 0.0);
      }
      return out;
    }
  }
  return formatUr(statusCode(Status::Internal), reply.cycleId, reply.pose, true);
}

Result<std::string> formatStrictPoseFrame(const Pose& pose) {
  if (!representable(pose)) return fail(Status::Internal, "pose cannot be sent (non-finite or beyond +-99999.999 mm)");
  const Vec3 rv = toRotationVector(pose);
  const double values[6] = {pose.x / 1000.0, pose.y / 1000.0, pose.z / 1000.0, rv.x, rv.y, rv.z};
  if (anyNonFinite(values, 6)) return fail(Status::Internal, "rotation vector is not finite");
  std::string out;
  out.reserve(80);
  out.push_back('(');
  for (std::size_t i = 0; i < 6; ++i) {
    if (i > 0) out.push_back(',');
    appendFixed(out, values[i], 6);
  }
  out.push_back(')');
  return out;
}

}  // namespace vgr::protocol
