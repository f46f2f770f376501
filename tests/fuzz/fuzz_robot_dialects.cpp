// libFuzzer target: every robot dialect's codec as a server session uses it, plus the
// strict exchange. Input: byte 0 picks the dialect (ur, abb, fanuc, binary, strict), byte 1
// the chunk size (1..64), the rest is the robot's TCP byte stream.
//  - RequestDecoder fed in chunks: only the documented error codes, jobs in range, memory
//    bounded;
//  - for every decoded request, formatReply() in all four reply dialects with a pose made of
//    raw input bytes (NaN, infinities, huge values, non-unit quaternions included): each
//    reply within its dialect's contract (ABB <= 80 chars, FANUC exactly 75 bytes ending in
//    CR LF, binary 40 bytes with its magic, UR one parenthesised tuple), and the same with
//    reply_label and a raw label / confidence (ABB <= 80, UR 10 values, FANUC 85, binary 48);
//  - StrictExchange with the paper's tokens fed the same stream: every event legal for its
//    step, log details printable, back to Idle after Completed/Failed; with byte 0's top bit
//    set, in snapshot mode (eye-in-hand): every snapshot pose finite and a unit quaternion.
#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <cstring>
#include <string>
#include <string_view>

#include "protocol/robot_codec.hpp"
#include "protocol/robot_strict.hpp"

namespace {

using namespace vgr::protocol;

void check(bool ok) {
  if (!ok) std::abort();
}

// Eight bytes of the stream from `at` (wrapping) as a double: any bit pattern.
double rawDouble(std::string_view s, std::size_t at) {
  unsigned char b[8] = {};
  for (std::size_t i = 0; i < 8 && !s.empty(); ++i) b[i] = static_cast<unsigned char>(s[(at + i) % s.size()]);
  double v = 0;
  std::memcpy(&v, b, sizeof v);
  return v;
}

void checkReplies(std::string_view stream, std::size_t at, vgr::Status status, std::uint32_t cycle) {
  RobotReply reply;
  reply.status = status;
  reply.cycleId = cycle;
  reply.pose = {rawDouble(stream, at), rawDouble(stream, at + 8), rawDouble(stream, at + 16), rawDouble(stream, at + 24),
                rawDouble(stream, at + 32), rawDouble(stream, at + 40), rawDouble(stream, at + 48)};
  const std::string abb = formatReply(Dialect::Abb, reply);
  check(!abb.empty() && abb.size() <= kAbbMaxReplyChars);
  const std::string ur = formatReply(Dialect::Ur, reply);
  check(ur.size() >= 2 && ur.front() == '(' && ur.back() == ')' && ur.find(')') == ur.size() - 1);
  const std::string fanuc = formatReply(Dialect::Fanuc, reply);
  check(fanuc.size() == kFanucReplyChars && fanuc.ends_with("\r\n"));
  const std::string bin = formatReply(Dialect::Binary, reply);
  check(bin.size() == binary::kReplyBytes);
  check(static_cast<std::uint32_t>(binary::readInt32(bin, 0)) == binary::kReplyMagic);
  check(binary::readInt32(bin, 4) == static_cast<std::int32_t>(binary::kReplyBytes));

  // reply_label: any label and confidence bits (out of range ones must become errors, never
  // longer replies).
  std::int32_t rawLabel = 0;
  for (std::size_t i = 0; i < 4 && !stream.empty(); ++i)
    rawLabel = static_cast<std::int32_t>((static_cast<std::uint32_t>(rawLabel) << 8) |
                                         static_cast<unsigned char>(stream[(at + 56 + i) % stream.size()]));
  reply.label = rawLabel % 2000 - 500;  // mostly around [0, 999], some beyond
  reply.confidence = rawDouble(stream, at + 64);
  const std::string abbL = formatReply(Dialect::Abb, reply, true);
  check(!abbL.empty() && abbL.size() <= kAbbMaxReplyChars);
  const std::string urL = formatReply(Dialect::Ur, reply, true);
  check(urL.size() >= 2 && urL.front() == '(' && urL.back() == ')' && urL.find(')') == urL.size() - 1);
  std::size_t commas = 0;
  for (const char c : urL) commas += c == ',' ? 1 : 0;
  check(commas == 9);  // 10 values: socket_read_ascii_float(10), <= 30
  const std::string fanucL = formatReply(Dialect::Fanuc, reply, true);
  check(fanucL.size() == kFanucLabelReplyChars && fanucL.ends_with("\r\n"));
  const std::string binL = formatReply(Dialect::Binary, reply, true);
  check(binL.size() == binary::kLabelReplyBytes);
  check(binary::readInt32(binL, 4) == static_cast<std::int32_t>(binary::kLabelReplyBytes));
}

bool printableAscii(std::string_view s) {
  for (const char c : s)
    if (static_cast<unsigned char>(c) < 0x20 || static_cast<unsigned char>(c) > 0x7e) return false;
  return true;
}

void fuzzStrict(std::string_view stream, std::size_t chunk) {
  StrictExchange ex{StrictTokens{}};
  const std::string frame = "(0.100000,0.200000,0.300000,0.000000,0.000000,0.100000)";
  check(ex.begin(frame) == "MoveJ_pose");
  for (std::size_t pos = 0; pos < stream.size(); pos += chunk) {
    ex.feed(stream.substr(pos, chunk));
    for (int guard = 0; guard < 10000; ++guard) {
      const auto before = ex.step();
      const auto ev = ex.poll();
      if (ev.kind == StrictExchange::EventKind::None) break;
      check(printableAscii(ev.detail));
      switch (ev.kind) {
        case StrictExchange::EventKind::SendPose:
          check(before == StrictExchange::Step::AwaitReady && ev.bytes == frame);
          check(ex.step() == StrictExchange::Step::AwaitDone);
          break;
        case StrictExchange::EventKind::Completed:
          check(before == StrictExchange::Step::AwaitDone && ex.step() == StrictExchange::Step::Idle);
          break;
        case StrictExchange::EventKind::Failed:
          check(before != StrictExchange::Step::Idle && ex.step() == StrictExchange::Step::Idle);
          check(ev.status != vgr::Status::Ok);
          break;
        case StrictExchange::EventKind::Unexpected:
          check(before == StrictExchange::Step::Idle);
          break;
        case StrictExchange::EventKind::None: break;
      }
      if (ex.step() == StrictExchange::Step::Idle && (pos / chunk) % 2 == 0) ex.begin(frame);  // the next part
    }
  }
  if (ex.step() != StrictExchange::Step::Idle) {
    check(ex.onTimeout().kind == StrictExchange::EventKind::Failed);
  }
  check(ex.onClosed().kind == StrictExchange::EventKind::None);  // Idle: nothing to abort
}

// The eye-in-hand strict exchange: snapshots (token + pose frame) from the stream, answered
// alternately with a part (the four steps) and with nothing to move.
void fuzzStrictSnapshot(std::string_view stream, std::size_t chunk) {
  StrictTokens tokens;
  tokens.snapshot = "MoveJ_snapshot";
  StrictExchange ex{tokens};
  const std::string frame = "(0.100000,0.200000,0.300000,0.000000,0.000000,0.100000)";
  int snapshots = 0;
  for (std::size_t pos = 0; pos < stream.size(); pos += chunk) {
    ex.feed(stream.substr(pos, chunk));
    for (int guard = 0; guard < 10000; ++guard) {
      const auto before = ex.step();
      const auto ev = ex.poll();
      if (ev.kind == StrictExchange::EventKind::None) break;
      check(printableAscii(ev.detail));
      if (ev.kind == StrictExchange::EventKind::Snapshot) {
        check(before == StrictExchange::Step::Idle && ex.step() == StrictExchange::Step::AwaitResult);
        const auto& p = ev.pose;
        check(std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z));
        check(std::abs(p.qw * p.qw + p.qx * p.qx + p.qy * p.qy + p.qz * p.qz - 1.0) < 1e-9);
        if (++snapshots % 2 == 0) {
          check(ex.begin(frame) == "MoveJ_pose");
        } else {
          const std::string none = ex.noResult(vgr::Status::NoPartFound);
          check(none == "MoveJ_none(1)" && ex.step() == StrictExchange::Step::Idle);
        }
      } else if (ev.kind == StrictExchange::EventKind::BadSnapshot) {
        check(before == StrictExchange::Step::Idle && ex.step() == StrictExchange::Step::Idle);
        check(ev.status == vgr::Status::BadArgument);
      } else if (ev.kind == StrictExchange::EventKind::Unexpected) {
        check(before == StrictExchange::Step::Idle || before == StrictExchange::Step::AwaitResult);
      }
    }
  }
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  if (size < 2) return 0;
  static constexpr Dialect kDialects[] = {Dialect::Ur, Dialect::Abb, Dialect::Fanuc, Dialect::Binary, Dialect::Strict};
  const Dialect dialect = kDialects[data[0] % 5];
  const std::size_t chunk = 1 + data[1] % 64;
  const std::string_view stream(reinterpret_cast<const char*>(data + 2), size - 2);

  if (dialect == Dialect::Strict) {
    if (data[0] & 0x80)
      fuzzStrictSnapshot(stream, chunk);
    else
      fuzzStrict(stream, chunk);
    return 0;
  }
  RequestDecoder decoder(dialect);
  std::size_t n = 0;
  for (std::size_t pos = 0; pos < stream.size(); pos += chunk) {
    decoder.append(stream.substr(pos, chunk));
    while (auto next = decoder.next()) {
      ++n;
      if (!next->has_value()) {
        const auto code = next->error().code;
        check(code == vgr::Status::UnknownCommand || code == vgr::Status::BadArgument);
        checkReplies(stream, pos + n, code, 0);
        continue;
      }
      const RobotRequest& req = **next;
      check((req.job >= kMinJob && req.job <= kMaxJob) || req.job == 0);
      checkReplies(stream, pos + n, vgr::Status::Ok, static_cast<std::uint32_t>(req.job));
    }
  }
  return 0;
}
