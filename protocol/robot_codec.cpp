#include "protocol/robot_codec.hpp"

#include <array>
#include <charconv>
#include <cmath>
#include <system_error>

namespace vgr::protocol {
namespace {

constexpr double kRadToDeg = 180.0 / 3.14159265358979323846;

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
  return std::nullopt;
}

std::string_view dialectName(Dialect dialect) {
  switch (dialect) {
    case Dialect::Ur:
      return "ur";
    case Dialect::Abb:
      return "abb";
  }
  return "?";
}

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

  if (fields[0] != "GET") return fail(Status::UnknownCommand, "unknown command");
  if (count < 2 || fields[1].empty()) return fail(Status::BadArgument, "missing job number");

  int job = 0;
  const std::string_view jobText = fields[1];
  const auto [ptr, ec] = std::from_chars(jobText.data(), jobText.data() + jobText.size(), job);
  if (ec != std::errc{} || ptr != jobText.data() + jobText.size() || jobText.front() == '-') {
    return fail(Status::BadArgument, "job is not a number");
  }
  if (job < kMinJob || job > kMaxJob) return fail(Status::BadArgument, "job out of range [1, 32767]");

  RobotRequest req;
  req.job = job;
  if (count == 3) {
    if (fields[2] != "LAST") return fail(Status::BadArgument, "unknown option (expected LAST)");
    req.last = true;
  } else if (count > 3) {
    return fail(Status::BadArgument, "too many fields");
  }
  return req;
}

// ---------------------------------------------------------------------------------------
// Replies

std::string formatReply(Dialect dialect, const RobotReply& reply) {
  int status = statusCode(reply.status);
  bool zeroPose = reply.status != Status::Ok;
  if (!zeroPose && !representable(reply.pose)) {
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

  switch (dialect) {
    case Dialect::Ur:
      return formatUr(status, reply.cycleId, reply.pose, zeroPose);
    case Dialect::Abb: {
      std::string out = formatAbb(status, reply.cycleId, reply.pose, zeroPose);
      // Unreachable with the bounds above (worst case is 77 characters); kept so that a
      // future change of bounds can never send RAPID a truncated reply.
      if (out.size() > kAbbMaxReplyChars)
        out = formatAbb(statusCode(Status::Internal), reply.cycleId, reply.pose, true);
      return out;
    }
  }
  return formatUr(statusCode(Status::Internal), reply.cycleId, reply.pose, true);
}

}  // namespace vgr::protocol
