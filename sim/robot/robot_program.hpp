// The example robot programs of examples/robot/, read and played by vgr-sim-robot
// --program (docs/protocols.md, "Offsets and frames"): what an unmodified program sends
// and what it does with a reply, so a test can check the pose the robot would really move
// to against the renderer's truth. Read from the program text itself (as
// tests/integration/robot_languages_test.cpp reads requests and columns): its requests,
// its taught data (RAPID's work object and robtarget, the TP program's P[2] in its user
// frame, URScript's `ref` and `grip` poses) and the statements that apply the offset
// (PDispSet, Offset,PR[10], pose_trans), each checked to be there exactly. What a program
// cannot hold (FANUC's UFRAME[1] lives in the controller) and the job's reference come
// from the cell config, whose robot entry must agree with the program (offset mode, the
// frame's name and, for RAPID, its pose).
//
//   abb   (VgrPick.mod)            TCP = wobj * D * pPick        D = [[x,y,z],OrientZYX(rz,ry,rx)]
//   fanuc (vgr_bg.kl + VGR_PICK.ls) TCP = UFRAME[1] * D * P[2]   D = PR[10] = (x,y,z,w,p,r)
//   ur    (vgr_offset.script)      TCP = ref * O * grip          O = p[x,y,z,rx,ry,rz]
// The part the robot picks is TCP * grip^-1, the grip being how the program's taught pick
// sits on the reference part (for abb and fanuc: (U^-1 R)^-1 * pick). RAPID num and KAREL
// REAL are 32-bit floats: their values pass through float first.
// Start-up code; not thread-safe; no sockets.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "config/cell_config.hpp"
#include "core/pose.hpp"
#include "core/result.hpp"

namespace vgr::sim {

struct RobotProgram {
  config::Dialect dialect = config::Dialect::Ur;
  std::vector<std::string> setup;  // requests sent once per connection before polling (RAPID: "JOB,1#")
  std::string request;             // the polling request, as the program sends it
  int job = 0;                     // the job the program works on
  Pose grip;                       // the taught pick relative to the part: TCP = part * grip
  // The TCP target in the base frame for an OK reply's six numbers, as the dialect carries
  // them (abb mm + rz,ry,rx deg; fanuc mm + w,p,r deg; ur m + rotation vector rad).
  std::function<Pose(const std::array<double, 6>&)> tcp;
  std::string summary;             // one line for the log
};

// `files`: the program's files (FANUC: vgr_bg.kl and VGR_PICK.ls). `robot`: the endpoint's
// name in `cell`. Errors (Status::BadArgument) say what is missing or disagrees.
Result<RobotProgram> loadRobotProgram(const std::vector<std::string>& files, config::Dialect dialect,
                                      const config::CellConfig& cell, const std::string& robot);

}  // namespace vgr::sim
