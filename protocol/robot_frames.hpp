// What a robot endpoint receives for a part: the arithmetic behind cell.yaml's
// `robots[].deliver` and `robots[].frame` (docs/protocols.md, "Offsets and frames").
// Frames: U = T_base_user (the endpoint's user / work-object frame, identity = the base
// frame), R = T_base_ref (the job's taught reference), P = T_base_part; all mm + quaternion.
//
//   deliver pose  : U^-1 P, the part in the user frame (every dialect).
//   deliver offset, by the robot language's way of applying one:
//     abb, fanuc, binary -> the displacement D = (U^-1 P)(U^-1 R)^-1, expressed in the user
//         frame, which moves the reference onto the part: D * (U^-1 R) = U^-1 P. A point
//         taught in the user frame with the reference part lying there moves with the part
//         when it is displaced by D: RAPID `PDispSet` (program displacement in the work
//         object's object frame; `Offs(p, x, y, z)` equals it when D has no rotation),
//         FANUC `Offset,PR[n]` (the position register applied as a frame in the user frame).
//     ur, strict -> O = R^-1 P, the part in the reference's own frame, for URScript's
//         `pose_trans(ref, O)` = ref * O (ref = the taught reference in whatever frame the
//         program moves in: O does not depend on U).
// Pure; any thread.
#pragma once

#include "core/pose.hpp"
#include "protocol/wire_types.hpp"

namespace vgr::protocol {

struct RobotFrame {
  Delivery delivery = Delivery::Pose;
  Pose baseFromUser;  // T_base_user; identity = the robot base frame
};

enum class OffsetConvention {
  Displacement,       // D = (U^-1 P)(U^-1 R)^-1 in the user frame (abb, fanuc, binary)
  ReferenceRelative,  // O = R^-1 P (ur, strict: pose_trans)
};
OffsetConvention offsetConvention(Dialect dialect);

// The pose the endpoint's dialect encodes for a part at `part` (base frame) of a job whose
// taught reference is `reference` (base frame).
Pose deliveredPose(Dialect dialect, const RobotFrame& frame, const Pose& reference, const Pose& part);

}  // namespace vgr::protocol
