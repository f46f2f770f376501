#include "protocol/robot_codec.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <system_error>

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

}  // namespace

Result<RobotRequest> parseRequest(std::string_view line) {
  // Split on commas (at most 4 fields looked at; more is an error anyway).
  std::array<std::string_view, 4> fields{};
  std::size_t count = 0;
  std::string_view rest = line;
  for (;;) {
    const std::size_t comma = rest.find(',');
    const std::string_view field = trim(rest.substr(0, comma));
    if (count < fields.size()) fields[count] = field;
    ++count;
    if (comma == std::string_view::npos) break;
    rest.remove_prefix(comma + 1);
  }

  RobotRequest req;
  if (fields[0] == "JOB") {
    if (count < 2) return fail(Status::BadArgument, "missing job number");
    if (count > 2) return fail(Status::BadArgument, "too many fields");
    auto job = parseJob(fields[1]);
    if (!job) return std::unexpected(job.error());
    req.command = Command::Job;
    req.job = *job;
    return req;
  }
  if (fields[0] == "TRIG") {
    req.command = Command::Trigger;
    if (count == 1) return req;  // "TRIG": the robot's current job
    if (count > 2) return fail(Status::BadArgument, "too many fields");
    auto job = parseJob(fields[1]);
    if (!job) return std::unexpected(job.error());
    req.job = *job;
    return req;
  }
  if (fields[0] != "GET") return fail(Status::UnknownCommand, "unknown command");
  if (count == 1) return req;  // "GET": the robot's current job

  auto job = parseJob(fields[1]);
  if (!job) return std::unexpected(job.error());
  req.job = *job;
  if (count == 3) {
    if (fields[2] != "LAST") return fail(Status::BadArgument, "unknown option (expected LAST)");
    req.last = true;
  } else if (count > 3) {
    return fail(Status::BadArgument, "too many fields");
  }
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

std::string encodeRequest(std::int32_t command, std::int32_t job) {
  std::string out;
  out.reserve(kRequestBytes);
  appendInt32(out, static_cast<std::int32_t>(kRequestMagic));
  appendInt32(out, static_cast<std::int32_t>(kRequestBytes));
  appendInt32(out, command);
  appendInt32(out, job);
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
    return parseRequest(**line);
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
  if (bin_.size() < binary::kRequestBytes) return std::nullopt;
  inGarbage_ = false;

  const std::string_view frame(bin_.data(), binary::kRequestBytes);
  const std::int32_t length = binary::readInt32(frame, 4);
  const std::int32_t command = binary::readInt32(frame, 8);
  const std::int32_t job = binary::readInt32(frame, 12);
  if (length != static_cast<std::int32_t>(binary::kRequestBytes)) {
    // The frame boundary is unknown: skip only the magic and look for the next one.
    // One bad frame, one error: what follows up to the next magic is not reported again.
    bin_.erase(0, 4);
    inGarbage_ = true;
    return Result<RobotRequest>(fail(Status::BadArgument, "binary request length is not 16"));
  }
  bin_.erase(0, binary::kRequestBytes);

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

std::string formatReply(Dialect dialect, const RobotReply& reply, bool withLabel) {
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
      std::string out = formatAbb(status, reply.cycleId, reply.pose, zeroPose);
      if (withLabel) appendLabelText(out, label, confidence);
      // Unreachable for the daemon's cycle ids (< 2^23: Ok replies are at most 68 characters,
      // 78 with the label); kept so that no bound can ever send RAPID a truncated reply.
      if (out.size() > kAbbMaxReplyChars) {
        out = formatAbb(statusCode(Status::Internal), reply.cycleId, reply.pose, true);
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
