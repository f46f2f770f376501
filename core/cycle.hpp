// The outcome of one cycle (trigger -> image -> localization -> pose), as handed to every
// output: Modbus registers, robot dialects and the journal.
#pragma once

#include <chrono>
#include <cstdint>
#include <optional>
#include <vector>

#include "core/pose.hpp"
#include "core/status.hpp"

namespace vgr {

// Cycle ids stay below 2^23 (RAPID's num is a float): they wrap to 1 after kMaxCycleId.
inline constexpr std::uint32_t kMaxCycleId = (1u << 23) - 1;

// What started a cycle: the PLC over Modbus (server or client mode), a robot's request, or
// the operator (vgrd's SIGUSR1). Recorded in the journal as "modbus", "robot", "operator".
enum class TriggerSource { Modbus, Robot, Operator };
const char* triggerSourceName(TriggerSource source);

struct PartResult {
  Pose pose;          // part (grasp point) in the robot base frame, mm
  Pose offset;        // T_ref^-1 * T_part: the offset from the job's taught reference
  double uPx = 0;     // grasp point in the image, pixels (x right, y down, pixel centres at integers)
  double vPx = 0;
  double angleImgDeg = 0;  // part rotation in the image, degrees, counter-clockwise as displayed
  double score = 0;        // 0..1
  int label = 0;           // part class (paper 002's labels); 0 when the method does not classify
};

struct CycleResult {
  std::uint32_t cycleId = 0;
  Status status = Status::Internal;
  int jobId = 0;
  TriggerSource trigger = TriggerSource::Modbus;
  std::uint64_t frameId = 0;   // camera frame (GVSP block) id, 0 when no frame
  // Eye-in-hand snapshot: T_base_flange the robot sent with its trigger (mm + quaternion).
  std::optional<Pose> flange;
  std::vector<PartResult> parts;  // best first
  double grabMs = 0, locateMs = 0, totalMs = 0;
  std::chrono::system_clock::time_point triggerTime;
  // The frame went to the image archive (vgrd's daemon/image_archive.hpp): the journal line
  // names its file ("archive"), derived from cycleId and triggerTime.
  bool archived = false;
};

}  // namespace vgr
