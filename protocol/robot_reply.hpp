// The robot's side of the request dialects (docs/protocols.md): one reply as a robot
// program reads it, checked strictly against the dialect, so a simulator or test robot
// notices every byte out of place. Pure: bytes in, numbers out; any thread.
//   ur    : exactly "(<status>,<cycle>,x,y,z,rx,ry,rz)" (6 decimals), as URScript's
//           socket_read_ascii_float(8) reads it: x/y/z in m, a rotation vector in rad.
//   abb   : "<status>,<cycle>,x,y,z,rz,ry,rx" (3 decimals), or with AbbRotation::Quaternion
//           "<status>,<cycle>,x,y,z,q1,q2,q3,q4" (q 5 decimals, unit within 2e-5 when the
//           status is 0), at most 80 characters (one RAPID SocketReceive \Str), no terminator.
//   fanuc : the 75-byte fixed-column line ending CR LF (KAREL READ + SUB_STR).
//   binary: the 40-byte VGRA frame.
// With withLabel (reply_label endpoints) the label and confidence follow the pose:
// ",<label>,<confidence>" (label 1-3 digits, fanuc 3; confidence "[01].ddd"), binary the
// 48-byte frame with two more int32 (label, confidence x 1000).
// Decoded to mm and the rotation as Z-Y-X Euler degrees rz, ry, rx (all six degrees of
// freedom, the journal's convention; for a planar part rz is the rotation about z), each
// rounded to 3 decimals.
#pragma once

#include <array>
#include <string_view>

#include "core/result.hpp"
#include "protocol/wire_types.hpp"

namespace vgr::protocol {

struct ParsedReply {
  int status = 0;
  long long cycle = 0;
  double xMm = 0, yMm = 0, zMm = 0, rzDeg = 0, ryDeg = 0, rxDeg = 0;
  // The six pose numbers as the dialect carries them, unrounded (ur: m and a rotation vector
  // in rad; abb: mm and Z-Y-X degrees; fanuc: mm and W, P, R degrees; binary: mm and
  // degrees): what a robot program computes its target from (sim/robot/robot_program.hpp).
  // Zeros for abb quaternion replies (no six-number form).
  std::array<double, 6> values{};
  // reply_label replies only (docs/protocols.md): the classifier's label [0, 999] and its
  // confidence [0, 1] after the pose (binary: the 48-byte frame).
  int label = 0;
  double confidence = 0;
};

// How the endpoint was configured to reply.
struct ReplyForm {
  AbbRotation abbRotation = AbbRotation::EulerZyx;  // abb only
  bool withLabel = false;
};

// The reply, or Status::BadArgument saying what is wrong with it ("does not match the
// dialect", "longer than 80 characters", "not a 40-byte VGRA frame" (48 with the label), "number out of range",
// "cycle id out of range": vgrd's cycle ids are in [0, 2^23 - 1], "label or confidence out
// of range").
// Dialect strict has no replies: BadArgument.
Result<ParsedReply> parseRobotReply(Dialect dialect, std::string_view raw, const ReplyForm& form = {});

}  // namespace vgr::protocol
