#if defined(__GNUC__) && !defined(__clang__)
// GCC 12 reports a false -Wmaybe-uninitialized inside <regex> in sanitizer builds.
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif

#include "protocol/robot_reply.hpp"

#include <algorithm>
#include <array>
#include <charconv>
#include <cmath>
#include <regex>
#include <string>

#include "core/cycle.hpp"
#include "core/pose.hpp"
#include "protocol/robot_codec.hpp"

namespace vgr::protocol {

namespace {

constexpr double kPi = 3.14159265358979323846;

double round3(double v) {
  const double r = std::round(v * 1000.0) / 1000.0;
  return r == 0.0 ? 0.0 : r;  // no -0
}

// Position and the Z-Y-X angles of the pose a reply carries, rounded to 3 decimals.
void setPose(ParsedReply& p, const Pose& pose) {
  const EulerZyxDeg e = toEulerZyxDeg(pose);
  p.xMm = round3(pose.x);
  p.yMm = round3(pose.y);
  p.zMm = round3(pose.z);
  p.rzDeg = round3(e.rz);
  p.ryDeg = round3(e.ry);
  p.rxDeg = round3(e.rx);
}

Result<ParsedReply> parseBinaryReply(std::string_view raw, bool withLabel) {
  const std::size_t bytes = withLabel ? binary::kLabelReplyBytes : binary::kReplyBytes;
  if (raw.size() != bytes || static_cast<std::uint32_t>(binary::readInt32(raw, 0)) != binary::kReplyMagic ||
      binary::readInt32(raw, 4) != static_cast<std::int32_t>(bytes))
    return fail(Status::BadArgument, withLabel ? "not a 48-byte VGRA frame" : "not a 40-byte VGRA frame");
  ParsedReply p;
  if (withLabel) {
    p.label = binary::readInt32(raw, 40);
    p.confidence = binary::readInt32(raw, 44) / 1000.0;
  }
  p.status = binary::readInt32(raw, 8);
  p.cycle = binary::readInt32(raw, 12);
  for (std::size_t i = 0; i < 6; ++i) p.values[i] = binary::readInt32(raw, 16 + 4 * i) / 1000.0;
  // x, y, z µm; w, p, r millidegrees (R = Rz(r)·Ry(p)·Rx(w))
  for (std::size_t i = 3; i < 6; ++i)
    if (!(std::abs(p.values[i]) <= 180.0005)) return fail(Status::BadArgument, "angle out of range");
  setPose(p, poseFromEulerZyxDeg(p.values[0], p.values[1], p.values[2], EulerZyxDeg{p.values[5], p.values[4], p.values[3]}));
  return p;
}

// What vgrd sends lies in these ranges; anything else is not a reply of vgrd's (found by
// fuzz_robot_reply: a binary reply with a negative cycle passed, and a ur reply with a
// 200-digit x that became infinite in mm). Cycle ids in [0, kMaxCycleId] (0: no cycle),
// statuses in [-99, 99], positions within kMaxAbsPositionMm, angles within 180 degrees
// (ur: a rotation vector's components within pi).
Result<ParsedReply> checkCycle(Result<ParsedReply> r) {
  if (!r) return r;
  if (r->cycle < 0 || r->cycle > static_cast<long long>(kMaxCycleId))
    return fail(Status::BadArgument, "cycle id out of range [0, 2^23 - 1]");
  if (r->status < -99 || r->status > 99) return fail(Status::BadArgument, "status out of range [-99, 99]");
  for (const double mm : {r->xMm, r->yMm, r->zMm})
    if (!(std::abs(mm) <= kMaxAbsPositionMm + 0.0005)) return fail(Status::BadArgument, "position out of range");
  for (const double deg : {r->rzDeg, r->ryDeg, r->rxDeg})
    if (!(std::abs(deg) <= 180.0005)) return fail(Status::BadArgument, "angle out of range");
  if (r->label < 0 || r->label > kMaxReplyLabel || !(r->confidence >= 0 && r->confidence <= 1.0))
    return fail(Status::BadArgument, "label or confidence out of range");
  return r;
}

Result<ParsedReply> parseTextReply(Dialect dialect, std::string_view raw, const ReplyForm& form);

}  // namespace

Result<ParsedReply> parseRobotReply(Dialect dialect, std::string_view raw, const ReplyForm& form) {
  if (dialect == Dialect::Binary) return checkCycle(parseBinaryReply(raw, form.withLabel));
  return checkCycle(parseTextReply(dialect, raw, form));
}

namespace {

Result<ParsedReply> parseTextReply(Dialect dialect, std::string_view raw, const ReplyForm& form) {
  if (dialect == Dialect::Strict) return fail(Status::BadArgument, "the strict dialect has no replies");
  static const std::regex kUr(R"(\(-?\d+,\d+(,-?\d+\.\d{6}){6}\))");
  static const std::regex kAbb(R"(-?\d+,\d+(,-?\d+\.\d{3}){6})");
  static const std::regex kAbbQuat(R"(-?\d+,\d+(,-?\d+\.\d{3}){3}(,-?\d\.\d{5}){4})");
  // Fixed columns: status, cycle, X, Y, Z, W, P, R, CR LF (docs/protocols.md, "fanuc").
  static const std::regex kFanuc(R"([+-]\d{4},\d{7}(,[+-]\d{5}\.\d{3}){3}(,[+-]\d{3}\.\d{3}){3}\r\n)");
  // reply_label: label and confidence after the pose.
  static const std::regex kUrLabel(R"(\(-?\d+,\d+(,-?\d+\.\d{6}){6},\d{1,3},[01]\.\d{3}\))");
  static const std::regex kAbbLabel(R"(-?\d+,\d+(,-?\d+\.\d{3}){6},\d{1,3},[01]\.\d{3})");
  static const std::regex kAbbQuatLabel(R"(-?\d+,\d+(,-?\d+\.\d{3}){3}(,-?\d\.\d{5}){4},\d{1,3},[01]\.\d{3})");
  static const std::regex kFanucLabel(R"([+-]\d{4},\d{7}(,[+-]\d{5}\.\d{3}){3}(,[+-]\d{3}\.\d{3}){3},\d{3},[01]\.\d{3}\r\n)");
  const bool quat = dialect == Dialect::Abb && form.abbRotation == AbbRotation::Quaternion;
  const bool lab = form.withLabel;
  const std::regex& re = dialect == Dialect::Ur      ? (lab ? kUrLabel : kUr)
                         : dialect == Dialect::Fanuc ? (lab ? kFanucLabel : kFanuc)
                         : quat                      ? (lab ? kAbbQuatLabel : kAbbQuat)
                                                     : (lab ? kAbbLabel : kAbb);
  if (!std::regex_match(raw.begin(), raw.end(), re)) return fail(Status::BadArgument, "does not match the dialect");
  if (dialect == Dialect::Abb && raw.size() > kAbbMaxReplyChars) return fail(Status::BadArgument, "longer than 80 characters");
  std::string_view body(raw);
  if (dialect == Dialect::Ur) body = body.substr(1, body.size() - 2);
  if (dialect == Dialect::Fanuc) body = body.substr(0, body.size() - 2);
  ParsedReply p;
  std::array<double, 9> v{};
  const std::size_t poseFields = quat ? 9 : 8;  // with status and cycle
  const std::size_t fields = poseFields + (lab ? 2 : 0);
  for (std::size_t field = 0; field < fields; ++field) {
    const std::size_t comma = body.find(',');
    std::string_view text = body.substr(0, comma);
    if (!text.empty() && text.front() == '+') text.remove_prefix(1);  // from_chars takes no '+'
    std::from_chars_result res{};
    if (field == 0)
      res = std::from_chars(text.data(), text.data() + text.size(), p.status);
    else if (field == 1)
      res = std::from_chars(text.data(), text.data() + text.size(), p.cycle);
    else
      res = std::from_chars(text.data(), text.data() + text.size(), v[field - 2]);
    if (res.ec != std::errc{}) return fail(Status::BadArgument, "number out of range");
    if (comma == std::string_view::npos) break;
    body.remove_prefix(comma + 1);
  }
  if (lab) {  // v holds the values after status and cycle
    p.label = static_cast<int>(v[poseFields - 2]);
    p.confidence = v[poseFields - 1];
  }
  if (quat) {  // mm + q1..q4 (w, x, y, z), unit (5 decimals: within 2e-5) when a pose is sent
    const double n = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
    if (!(n > 0.5) || (p.status == 0 && std::abs(n - 1.0) > 2e-5))
      return fail(Status::BadArgument, "quaternion is not a unit quaternion");
    setPose(p, poseFromQuaternion(v[0], v[1], v[2], v[3], v[4], v[5], v[6]));
    return p;
  }
  for (std::size_t i = 3; i < 6; ++i) {  // ur: a rotation vector (rad); abb, fanuc: degrees
    if (!(std::abs(v[i]) <= (dialect == Dialect::Ur ? kPi + 1e-6 : 180.0005)))
      return fail(Status::BadArgument, "angle out of range");
  }
  std::copy(v.begin(), v.begin() + 6, p.values.begin());
  if (dialect == Dialect::Ur)  // metres + rotation vector
    setPose(p, poseFromRotationVector(v[0] * 1000.0, v[1] * 1000.0, v[2] * 1000.0, Vec3{v[3], v[4], v[5]}));
  else if (dialect == Dialect::Fanuc)  // mm + W, P, R degrees (R = Rz(R)·Ry(P)·Rx(W))
    setPose(p, poseFromEulerZyxDeg(v[0], v[1], v[2], EulerZyxDeg{v[5], v[4], v[3]}));
  else  // abb: mm + Z-Y-X degrees rz, ry, rx
    setPose(p, poseFromEulerZyxDeg(v[0], v[1], v[2], EulerZyxDeg{v[3], v[4], v[5]}));
  return p;
}

}  // namespace
}  // namespace vgr::protocol
