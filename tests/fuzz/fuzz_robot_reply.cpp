// libFuzzer target: the robot side of the request dialects (protocol/robot_reply.hpp), the
// strict reply checker vgr-sim-robot and `vgr soak` read every reply with. Byte 0's bit 6
// picks the label form (reply_label), bit 5 abb's quaternion form; two modes by its top bit:
//   0: raw bytes as a reply of the dialect byte 0 picks (ur, abb, fanuc, binary): accepted
//      replies have finite numbers (six degrees of freedom), label and confidence in range
//      and the dialect's size limits;
//   1: a reply built from the input bytes (status, cycle, a pose of raw doubles: NaN, inf,
//      huge) is formatted by vgrd's formatReply() and must be accepted by the checker with
//      the same status and cycle, and its position within the dialect's rounding: every
//      byte vgrd sends is one a robot can read.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "core/pose.hpp"
#include "protocol/robot_codec.hpp"
#include "protocol/robot_reply.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

using vgr::protocol::Dialect;

constexpr Dialect kDialects[] = {Dialect::Ur, Dialect::Abb, Dialect::Fanuc, Dialect::Binary};

template <class T>
T take(const std::uint8_t*& p, std::size_t& left) {
  T v{};
  const std::size_t n = left < sizeof v ? left : sizeof v;
  std::memcpy(&v, p, n);
  p += n;
  left -= n;
  return v;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vgr::protocol;
  if (size == 0) return 0;
  const Dialect d = kDialects[data[0] % 4];
  ReplyForm form;
  form.withLabel = (data[0] & 0x40) != 0;
  form.abbRotation = (data[0] & 0x20) != 0 ? AbbRotation::Quaternion : AbbRotation::EulerZyx;
  if ((data[0] & 0x80) == 0) {
    const std::string_view raw(reinterpret_cast<const char*>(data + 1), size - 1);
    const auto r = parseRobotReply(d, raw, form);
    if (!r) {
      check(r.error().code == vgr::Status::BadArgument);
      return 0;
    }
    check(std::isfinite(r->xMm) && std::isfinite(r->yMm) && std::isfinite(r->zMm) && std::isfinite(r->rzDeg) &&
          std::isfinite(r->ryDeg) && std::isfinite(r->rxDeg));
    check(r->label >= 0 && r->label <= kMaxReplyLabel && r->confidence >= 0 && r->confidence <= 1);
    check(r->cycle >= 0);
    if (d == Dialect::Abb) check(raw.size() <= kAbbMaxReplyChars);
    if (d == Dialect::Fanuc) check(raw.size() == (form.withLabel ? kFanucLabelReplyChars : kFanucReplyChars));
    if (d == Dialect::Binary) check(raw.size() == (form.withLabel ? binary::kLabelReplyBytes : binary::kReplyBytes));
    return 0;
  }
  const std::uint8_t* p = data + 1;
  std::size_t left = size - 1;
  RobotReply reply;
  static const vgr::Status kStatuses[] = {vgr::Status::Ok, vgr::Status::NoPartFound, vgr::Status::ResultNotReady,
                                          vgr::Status::NoNewTrigger, vgr::Status::UnknownCommand, vgr::Status::BadArgument,
                                          vgr::Status::CameraError, vgr::Status::ProcessingTimeout,
                                          vgr::Status::JobNotFound, vgr::Status::Internal, vgr::Status::NotPermitted};
  reply.status = kStatuses[take<std::uint8_t>(p, left) % (sizeof kStatuses / sizeof kStatuses[0])];
  reply.cycleId = take<std::uint32_t>(p, left) % (1u << 23);
  const double x = take<double>(p, left), y = take<double>(p, left), z = take<double>(p, left);
  const double rz = take<double>(p, left);
  reply.pose = vgr::poseFromXyzRz(x, y, z, std::isfinite(rz) ? std::fmod(rz, 6.3) : rz);
  reply.label = take<std::uint16_t>(p, left) % (kMaxReplyLabel + 1);
  reply.confidence = take<std::uint16_t>(p, left) % 1001 / 1000.0;
  // config/ refuses abb_rotation quaternion together with reply_label (80 characters).
  if (form.withLabel) form.abbRotation = AbbRotation::EulerZyx;
  const std::string wire = formatReply(d, reply, form.withLabel, form.abbRotation);
  const auto parsed = parseRobotReply(d, wire, form);
  check(parsed.has_value());
  check(parsed->cycle == static_cast<long long>(reply.cycleId));
  // formatReply turns an unsendable pose into INTERNAL with zeros, keeping the cycle.
  const bool sendable = reply.status == vgr::Status::Ok && std::isfinite(x) && std::isfinite(y) && std::isfinite(z) &&
                        std::isfinite(rz) && std::abs(x) <= kMaxAbsPositionMm && std::abs(y) <= kMaxAbsPositionMm &&
                        std::abs(z) <= kMaxAbsPositionMm;
  if (reply.status != vgr::Status::Ok) {
    check(parsed->status == vgr::statusCode(reply.status));
    check(parsed->xMm == 0 && parsed->yMm == 0 && parsed->zMm == 0);
  } else if (sendable) {
    check(parsed->status == 0);
    // ur: µm (6 decimals of m); abb, fanuc: 3 decimals of mm; binary: µm.
    check(std::abs(parsed->xMm - x) <= 0.0011 && std::abs(parsed->yMm - y) <= 0.0011 && std::abs(parsed->zMm - z) <= 0.0011);
  } else {
    check(parsed->status == vgr::statusCode(vgr::Status::Internal) || parsed->status == 0);
  }
  return 0;
}
