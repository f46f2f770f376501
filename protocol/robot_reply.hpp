// The robot's side of the request dialects (docs/protocols.md): one reply as a robot
// program reads it, checked strictly against the dialect, so a simulator or test robot
// notices every byte out of place. Pure: bytes in, numbers out; any thread.
//   ur    : exactly "(<status>,<cycle>,x,y,z,rx,ry,rz)" (6 decimals), as URScript's
//           socket_read_ascii_float(8) reads it: x/y/z in m, a rotation vector in rad.
//   abb   : "<status>,<cycle>,x,y,z,rz,ry,rx" (3 decimals), at most 80 characters (one
//           RAPID SocketReceive \Str), no terminator.
//   fanuc : the 75-byte fixed-column line ending CR LF (KAREL READ + SUB_STR).
//   binary: the 40-byte VGRA frame.
// Decoded to mm and the rotation about z in degrees (planar parts: rz is the rotation
// vector's z for ur, the first Z-Y-X angle for abb, R for fanuc and binary), each rounded to
// 3 decimals.
#pragma once

#include <array>
#include <string_view>

#include "core/result.hpp"
#include "protocol/wire_types.hpp"

namespace vgr::protocol {

struct ParsedReply {
  int status = 0;
  long long cycle = 0;
  double xMm = 0, yMm = 0, zMm = 0, rzDeg = 0;
  // The six pose numbers as the dialect carries them, unrounded (ur: m and a rotation vector
  // in rad; abb: mm and Z-Y-X degrees; fanuc: mm and W, P, R degrees; binary: mm and
  // degrees): what a robot program computes its target from (sim/robot/robot_program.hpp).
  std::array<double, 6> values{};
  // reply_label replies only (docs/protocols.md): the classifier's label [0, 999] and its
  // confidence [0, 1] after the pose (binary: the 48-byte frame).
  int label = 0;
  double confidence = 0;
};

// The reply, or Status::BadArgument saying what is wrong with it ("does not match the
// dialect", "longer than 80 characters", "not a 40-byte VGRA frame", "number out of range",
// "cycle id out of range": vgrd's cycle ids are in [0, 2^23 - 1]).
// Dialect strict has no replies: BadArgument. `withLabel`: the endpoint's reply_label form,
// label and confidence after the pose ("label or confidence out of range" otherwise).
Result<ParsedReply> parseRobotReply(Dialect dialect, std::string_view raw, bool withLabel = false);

}  // namespace vgr::protocol
