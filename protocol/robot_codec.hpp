// Robot dialect codec: request framing and parsing, reply formatting (PROTOCOLS.md,
// "Dialects vgrd offers", the `ur` and `abb` dialects). Pure: bytes in, messages out, no
// sockets, no threads, no global state; every function here is safe to call from any
// thread (a RequestSplitter object is not shared between threads).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "core/status.hpp"

namespace vgr::protocol {

// One wire dialect per robot endpoint, chosen in the cell config.
enum class Dialect {
  Ur,   // URScript client: socket_send_line("GET,<job>") / socket_read_ascii_float(8)
  Abb,  // RAPID client: SocketSend \Str:="GET,<job>#" / SocketReceive \Str (<= 80 chars)
};

// "ur" or "abb" (lower case, exactly as written in cell.yaml); nullopt otherwise.
std::optional<Dialect> parseDialect(std::string_view text);
// "ur" / "abb".
std::string_view dialectName(Dialect dialect);

// Longest request line accepted, terminator excluded. Real requests are ~12 bytes.
inline constexpr std::size_t kMaxRequestBytes = 256;
// Longest reply a RAPID SocketReceive \Str can take in one call.
inline constexpr std::size_t kAbbMaxReplyChars = 80;
// Largest |x|, |y|, |z| (mm) a reply may carry; beyond it the reply is INTERNAL with zeros.
// Bounds the ABB reply to 80 characters; also applied to UR so both dialects agree.
inline constexpr double kMaxAbsPositionMm = 99999.999;

// Splits a byte stream into requests. A request ends at '#', CR or LF; CRLF (or any run of
// terminators) counts once because empty requests, and requests made only of spaces and
// tabs, are dropped (answering them would shift every later reply by one). A request
// longer than maxRequestBytes yields ONE error (Status::UnknownCommand, "request too
// long"); the splitter then discards input up to and including the next terminator and
// resynchronises there. Memory held: at most maxRequestBytes plus the last append().
class RequestSplitter {
 public:
  explicit RequestSplitter(std::size_t maxRequestBytes = kMaxRequestBytes);

  // Adds received bytes (any content, including NUL and non-ASCII).
  void append(std::string_view bytes);

  // The next complete request without its terminator, an Error for an over-long one, or
  // nullopt when no complete request is buffered yet (then call append() again).
  std::optional<Result<std::string>> next();

  // Bytes buffered that do not yet form a complete request.
  std::size_t buffered() const { return buffer_.size() - scanPos_; }
  // True while skipping the rest of an over-long request.
  bool discarding() const { return discarding_; }

 private:
  std::size_t maxRequestBytes_;
  std::string buffer_;
  std::size_t scanPos_ = 0;  // start of the not-yet-consumed part of buffer_
  bool discarding_ = false;
};

inline constexpr int kMinJob = 1;
inline constexpr int kMaxJob = 32767;

struct RobotRequest {
  int job = 0;        // [kMinJob, kMaxJob]
  bool last = false;  // "GET,<job>,LAST": deliver the latest result again
};

// Parses one request line (terminator already removed): "GET,<job>" or "GET,<job>,LAST".
// The command and LAST are case-sensitive; spaces and tabs around fields are tolerated;
// job is a decimal integer in [1, 32767] without sign. Errors: an unknown or missing
// command -> Status::UnknownCommand (-1); a bad, missing or out-of-range job or an
// unexpected extra field -> Status::BadArgument (-2).
Result<RobotRequest> parseRequest(std::string_view line);

struct RobotReply {
  Status status = Status::Ok;
  std::uint32_t cycleId = 0;  // kept below 2^23 by the daemon (RAPID num is a float32)
  Pose pose;                  // mm + unit quaternion, robot base/user frame; ignored unless Ok
};

// Formats one reply, ready to send in ONE write, no terminator:
//  ur : "(<status>,<cycle>,<x>,<y>,<z>,<rx>,<ry>,<rz>)", x/y/z in metres and the rotation
//       vector in radians, 6 decimals; socket_read_ascii_float(8) returns exactly these 8
//       values. Matches \(-?\d+,\d+(,-?\d+\.\d{6}){6}\)
//  abb: "<status>,<cycle>,<x>,<y>,<z>,<rz>,<ry>,<rx>", mm and Z-Y-X Euler degrees
//       (OrientZYX(rz, ry, rx)), 3 decimals, at most 80 characters. Matches
//       -?\d+,\d+(,-?\d+\.\d{3}){6}
// Numbers are locale-independent fixed notation, never an exponent, NaN or "-0.000".
// A reply whose status is not Ok carries a zero pose. A pose with a non-finite component
// or |x|, |y|, |z| > kMaxAbsPositionMm becomes status Internal (-8) with a zero pose,
// keeping the cycle id.
std::string formatReply(Dialect dialect, const RobotReply& reply);

}  // namespace vgr::protocol
