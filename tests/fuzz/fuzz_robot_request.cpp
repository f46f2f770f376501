// libFuzzer target: the robot request framing and parsing of protocol/robot_codec.hpp, as
// the robot servers use them on bytes from the network: RequestSplitter fed in chunks, then
// parseRequest() on every line in every text dialect's pose notation (eye-in-hand snapshots:
// TRIG,<job>,<pose>), then formatReply() of an answer for the text dialects.
// Input: byte 0 picks the chunk size (1..64), the rest is the TCP byte stream.
// Checks (abort = finding): memory and UB via ASan/UBSan; the splitter's memory bound;
// parse results within the documented codes and ranges, a flange pose only with TRIG and
// always finite, within +-99999.999 mm and a unit quaternion; replies within the dialects'
// limits (ABB <= 80 characters in both rotation forms, UR one parenthesised tuple).
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <string>
#include <string_view>

#include "protocol/robot_codec.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  using namespace vgr::protocol;
  if (size == 0) return 0;
  const std::size_t chunk = 1 + data[0] % 64;
  const std::string_view stream(reinterpret_cast<const char*>(data + 1), size - 1);

  RequestSplitter splitter;
  for (std::size_t pos = 0; pos < stream.size(); pos += chunk) {
    const auto piece = stream.substr(pos, chunk);
    splitter.append(piece);
    while (auto next = splitter.next()) {
      if (!next->has_value()) {
        check(next->error().code == vgr::Status::UnknownCommand);
        continue;
      }
      const std::string& line = **next;
      check(line.size() <= kMaxRequestBytes);
      check(line.find_first_of("#\r\n") == std::string::npos);
      for (const Dialect d : {Dialect::Abb, Dialect::Fanuc, Dialect::Strict}) {
        const auto other = parseRequest(line, d);
        if (!other || !other->flange) continue;
        const vgr::Pose& f = *other->flange;
        check(other->command == Command::Trigger && other->job >= kMinJob && other->job <= kMaxJob);
        check(std::isfinite(f.x) && std::isfinite(f.y) && std::isfinite(f.z));
        check(std::abs(f.x) <= kMaxAbsPositionMm && std::abs(f.y) <= kMaxAbsPositionMm && std::abs(f.z) <= kMaxAbsPositionMm);
        check(std::abs(f.qw * f.qw + f.qx * f.qx + f.qy * f.qy + f.qz * f.qz - 1.0) < 1e-9 && f.qw >= 0);
      }
      const auto req = parseRequest(line, Dialect::Ur);
      if (req && req->flange) check(req->command == Command::Trigger && std::isfinite(req->flange->qw));
      RobotReply reply;
      if (req) {
        // 0 only for a bare "GET" (the robot's current job).
        check((req->job >= kMinJob && req->job <= kMaxJob) || req->job == 0);
        reply.cycleId = static_cast<std::uint32_t>(req->job);
      } else {
        check(req.error().code == vgr::Status::UnknownCommand || req.error().code == vgr::Status::BadArgument);
        reply.status = req.error().code;
      }
      // A pose built from the request bytes: any finite or non-finite value must still give
      // a bounded, well-formed reply.
      const double v = line.empty() ? 0.0 : (static_cast<double>(static_cast<unsigned char>(line[0])) - 128.0) * 1e3;
      reply.pose.x = v;
      reply.pose.y = -v;
      reply.pose.z = v / 7.0;
      const std::string abb = formatReply(Dialect::Abb, reply);
      check(!abb.empty() && abb.size() <= kAbbMaxReplyChars);
      if (req && req->flange) reply.pose = *req->flange;  // a real rotation too
      const std::string abbQ = formatReply(Dialect::Abb, reply, false, AbbRotation::Quaternion);
      check(!abbQ.empty() && abbQ.size() <= kAbbMaxReplyChars);
      const std::string ur = formatReply(Dialect::Ur, reply);
      check(ur.size() >= 2 && ur.front() == '(' && ur.back() == ')');
    }
    // Memory held: at most one over-long request plus the last append.
    check(splitter.buffered() <= kMaxRequestBytes + piece.size() + 1);
  }
  return 0;
}
