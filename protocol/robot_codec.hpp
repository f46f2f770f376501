// Robot dialect codec: request framing and parsing, reply formatting (PROTOCOLS.md,
// "Dialects vgrd offers": `ur`, `abb`, `fanuc`, `binary`; the `strict` exchange is in
// protocol/robot_strict.hpp). Pure: bytes in, messages out, no sockets, no threads, no
// global state; every function here is safe to call from any thread (a RequestSplitter or
// RequestDecoder object is not shared between threads).
#pragma once

#include <cstddef>
#include <cstdint>
#include <optional>
#include <string>
#include <string_view>

#include "core/pose.hpp"
#include "core/result.hpp"
#include "core/status.hpp"
#include "protocol/wire_types.hpp"  // Dialect, AbbRotation

namespace vgr::protocol {

// Longest request line accepted, terminator excluded. Real requests are ~12 bytes.
inline constexpr std::size_t kMaxRequestBytes = 256;
// Longest reply a RAPID SocketReceive \Str can take in one call.
inline constexpr std::size_t kAbbMaxReplyChars = 80;
// KAREL STRING[254] is the longest string a READ can fill; the fanuc reply is fixed at
// kFanucReplyChars (CR LF included), far below it.
inline constexpr std::size_t kFanucMaxReplyChars = 254;
inline constexpr std::size_t kFanucReplyChars = 75;
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

enum class Command {
  Get,      // "GET[,<job>[,LAST]]": the next part (or, with LAST, the latest reply again)
  Job,      // "JOB,<job>": switch this robot's current job (what "GET" without a job means)
  Trigger,  // "TRIG[,<job>]": start a cycle of the job and answer with its result (a robot
            // asking for a part, with no PLC in the loop); "TRIG,<job>,<pose>" (or
            // "GET,<job>,<pose>") is an eye-in-hand snapshot: the flange pose at the image
};

struct RobotRequest {
  Command command = Command::Get;
  int job = 0;        // [kMinJob, kMaxJob]; 0 only for "GET" = the robot's current job
  bool last = false;  // "GET,<job>,LAST": deliver the latest reply again
  // Eye-in-hand snapshot: T_base_flange when the robot asked (mm + unit quaternion), in the
  // frame the hand-eye calibration's robot poses were given in. Only with Command::Trigger.
  std::optional<Pose> flange;
};

// A pose as a robot sends it in a request, in its dialect's own notation (docs/protocols.md,
// "Eye-in-hand snapshots"):
//   ur, strict: x, y, z in metres and a rotation vector in radians: 6 numbers, or the way
//               URScript prints a pose, "p[x, y, z, rx, ry, rz]"
//   abb:   x, y, z in mm and a quaternion q1, q2, q3, q4 (w, x, y, z: a RAPID orient; 7
//          numbers), or Z-Y-X Euler degrees rz, ry, rx (6 numbers, the reply's order), or
//          RAPID's ValToStr of a pose "[[x,y,z],[q1,q2,q3,q4]]"
//   fanuc: x, y, z in mm and W, P, R in degrees, R = Rz(R)·Ry(P)·Rx(W) (6 numbers)
// Numbers: decimal, optional sign, fraction and exponent, blanks around them allowed.
// Errors (Status::BadArgument, the message says which field and why): a wrong count, not a
// number, not finite, |x|, |y| or |z| beyond kMaxAbsPositionMm, and rotations that are not
// rotations: a quaternion whose norm is off 1 by more than kMaxQuaternionNormError, an Euler
// angle beyond +-360 degrees, a rotation vector longer than 2 pi. The binary dialect has no
// text pose (its 40-byte request frame carries one).
inline constexpr double kMaxQuaternionNormError = 1e-3;
Result<Pose> parsePose(Dialect dialect, std::string_view text);

// Parses one request line (terminator already removed): "GET", "GET,<job>",
// "GET,<job>,LAST", "JOB,<job>", "TRIG", "TRIG,<job>", and the eye-in-hand snapshot
// "TRIG,<job>,<pose>" (also written "GET,<job>,<pose>"; both become Command::Trigger with
// `flange`), the pose in `dialect`'s notation (parsePose). Commands and LAST are
// case-sensitive; spaces and tabs around fields are tolerated; job is a decimal integer in
// [1, 32767] without sign.
// Errors: an unknown command -> Status::UnknownCommand (-1); a bad, empty or out-of-range
// job, a bad pose or an unexpected extra field -> Status::BadArgument (-2).
// `dialect` only decides how a pose is read (irrelevant for requests without one).
Result<RobotRequest> parseRequest(std::string_view line, Dialect dialect = Dialect::Ur);

// The `binary` dialect (docs/protocols.md has the byte-by-byte layout). Every field is an
// int32, big-endian (network order), so URScript's socket_read_binary_integer and RAPID's
// UnpackRawBytes \IntX:=DINT \Network read each one directly.
//   request, 16 bytes: magic 'VGRQ' (0x56475251), length 16, command, job
//   request with a flange pose (eye-in-hand snapshot), 40 bytes: magic, length 40, command
//                      (GET or TRIG), job, x, y, z in µm, w, p, r in millidegrees
//   reply,   40 bytes: magic 'VGRA' (0x56475241), length 40, status, cycle,
//                      x, y, z in µm, w, p, r in millidegrees (R = Rz(r)·Ry(p)·Rx(w))
namespace binary {
inline constexpr std::uint32_t kRequestMagic = 0x56475251;  // "VGRQ"
inline constexpr std::uint32_t kReplyMagic = 0x56475241;    // "VGRA"
inline constexpr std::size_t kRequestBytes = 16;
inline constexpr std::size_t kPoseRequestBytes = 40;
inline constexpr std::size_t kReplyBytes = 40;
inline constexpr std::size_t kLabelReplyBytes = 48;  // withLabel: + label, + confidence x 1000
inline constexpr std::int32_t kCmdGet = 1;      // job 0 = the robot's current job
inline constexpr std::int32_t kCmdGetLast = 2;  // job 0 = the robot's current job
inline constexpr std::int32_t kCmdJob = 3;      // job in [1, 32767]
inline constexpr std::int32_t kCmdTrigger = 4;  // job 0 = the robot's current job
// Encodes a request frame (robot side; used by tests and vgr-sim-robot); with `flange` the
// 40-byte frame (µm and millidegrees, rounded).
std::string encodeRequest(std::int32_t command, std::int32_t job, const std::optional<Pose>& flange = std::nullopt);
// Reads the int32 at byte offset `at` of a frame (big-endian). Precondition: at + 4 <= size.
std::int32_t readInt32(std::string_view frame, std::size_t at);
}  // namespace binary

// Turns a byte stream into requests for one dialect: text dialects through
// RequestSplitter + parseRequest; `binary` through 16- and 40-byte frames. A binary stream
// that does not start with the request magic yields ONE Status::UnknownCommand error per
// run of garbage and resynchronises at the next magic; a frame with a wrong length, an
// unknown command, a bad job or a pose with a command other than GET and TRIG yields
// Status::BadArgument / UnknownCommand and the frame is skipped. Memory held: bounded by the splitter's limit or kMaxRequestBytes.
class RequestDecoder {
 public:
  explicit RequestDecoder(Dialect dialect);
  void append(std::string_view bytes);
  // The next decoded request or error, or nullopt when more bytes are needed.
  std::optional<Result<RobotRequest>> next();
  // After next() returned nullopt: bytes of a request that is not complete yet (a text
  // request being skipped for its length counts as 1); 0 between requests.
  std::size_t partial() const;

 private:
  Dialect dialect_;
  RequestSplitter text_;
  std::string bin_;
  bool inGarbage_ = false;  // binary: an error was already reported for the current run
};

struct RobotReply {
  Status status = Status::Ok;
  std::uint32_t cycleId = 0;  // kept below 2^23 by the daemon (RAPID num is a float32)
  Pose pose;                  // mm + unit quaternion, robot base/user frame; ignored unless Ok
  int label = 0;              // the part's class (paper 002), 0 = none; sent only with withLabel
  double confidence = 0;      // [0, 1]: the classifier's confidence in `label`
};

// Largest label a reply with the label fields can carry (3 digits: the ABB reply stays within
// 80 characters, the fanuc columns are 3 wide). A larger label makes the reply Internal (-8).
inline constexpr int kMaxReplyLabel = 999;
// Replies with withLabel: the fanuc reply is kFanucLabelReplyChars, the binary one
// binary::kLabelReplyBytes.
inline constexpr std::size_t kFanucLabelReplyChars = 85;

// Formats one reply, ready to send in ONE write:
//  ur : "(<status>,<cycle>,<x>,<y>,<z>,<rx>,<ry>,<rz>)", x/y/z in metres and the rotation
//       vector in radians, 6 decimals; socket_read_ascii_float(8) returns exactly these 8
//       values. Matches \(-?\d+,\d+(,-?\d+\.\d{6}){6}\)
//  abb: "<status>,<cycle>,<x>,<y>,<z>,<rz>,<ry>,<rx>", mm and Z-Y-X Euler degrees
//       (OrientZYX(rz, ry, rx)), 3 decimals, at most 80 characters. Matches
//       -?\d+,\d+(,-?\d+\.\d{3}){6}
//       With AbbRotation::Quaternion: "<status>,<cycle>,<x>,<y>,<z>,<q1>,<q2>,<q3>,<q4>", mm
//       with 3 decimals and the unit quaternion (w, x, y, z; q1 >= 0) with 5 decimals, at
//       most 78 characters. Matches -?\d+,\d+(,-?\d+\.\d{3}){3}(,-?\d\.\d{5}){4}
//  fanuc: fixed columns, sign-padded, then CR LF, always kFanucReplyChars (75) bytes:
//       "+0000,0004711,+00512.300,-00120.050,+00035.000,+000.000,+000.000,-012.500\r\n"
//       status cols 1-5, cycle 7-13, X 15-24, Y 26-35, Z 37-46 (mm), W 48-55, P 57-64,
//       R 66-73 (degrees, R = Rz(R)·Ry(P)·Rx(W)), commas in between (1-based columns, as
//       KAREL's SUB_STR counts).
//  binary: the 40-byte reply frame above.
//  strict: never a reply to a request (the strict session pushes; see robot_strict.hpp);
//       formats like `ur` so that a stray call still produces a well-formed line.
// Numbers are locale-independent fixed notation, never an exponent, NaN or "-0.000".
// A reply whose status is not Ok carries a zero pose. A pose with a non-finite component
// or |x|, |y|, |z| > kMaxAbsPositionMm becomes status Internal (-8) with a zero pose,
// keeping the cycle id.
//
// withLabel (a robot's `reply_label: true`, docs/protocols.md): the part's label and its
// confidence follow the pose, in every dialect that has room for them:
//  ur : 10 values, "(...,<rz>,<label>,<confidence>)": socket_read_ascii_float(10) (<= 30)
//  abb: "...,<rx>,<label>,<confidence>", still at most 80 characters (Ok replies <= 78)
//  fanuc: ",LLL,C.CCC" in columns 74-83 (label 3 digits at 75-77, confidence at 79-83),
//       then CR LF: kFanucLabelReplyChars (85) bytes
//  binary: two more int32, label and confidence x 1000: binary::kLabelReplyBytes (48), length 48
//  strict: no (its pose frame is paper 002's six values the robot moves to); ignored.
// The confidence has 3 decimals (x 1000 in binary); a reply that is not Ok carries 0 and
// 0.000. A label outside [0, kMaxReplyLabel] or a confidence outside [0, 1] makes an Ok
// reply Internal (-8) with zeros.
//
// abbRotation (dialect abb only, cell.yaml robots[].abb_rotation): the rotation as Z-Y-X
// Euler degrees rz, ry, rx (default) or the quaternion q1..q4 (w, x, y, z, 5 decimals, q1 >= 0).
// A quaternion reply is at most 78 characters; with the label it can exceed 80, and then
// becomes Internal (-8) with zeros (config/ refuses that combination).
std::string formatReply(Dialect dialect, const RobotReply& reply, bool withLabel = false,
                        AbbRotation abbRotation = AbbRotation::EulerZyx);

// The strict dialect's pose frame (paper 002: "{x, y, z, Rx, Ry, Rz} encoded in a byte
// frame"): "(<x>,<y>,<z>,<rx>,<ry>,<rz>)" in metres and a rotation vector in radians, 6
// decimals, which URScript's socket_read_ascii_float(6) turns into p[x, y, z, rx, ry, rz].
// Error (Status::Internal) for a pose the wire cannot carry (non-finite, beyond
// kMaxAbsPositionMm).
Result<std::string> formatStrictPoseFrame(const Pose& pose);

// The strict dialect's snapshot pose (eye-in-hand): the robot's flange pose in the strict
// frame notation, "(<x>,<y>,<z>,<rx>,<ry>,<rz>)" in metres and radians, or as URScript prints
// a pose, "p[x, y, z, rx, ry, rz]" (socket_send_string(get_actual_tool_flange_pose())).
// `text` is exactly the frame. Errors as parsePose.
Result<Pose> parseStrictPoseFrame(std::string_view text);

}  // namespace vgr::protocol
