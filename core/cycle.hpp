// The outcome of one cycle (trigger -> image -> localization -> pose), as handed to every
// output: Modbus registers, robot dialects and the journal.
#pragma once

#include <chrono>
#include <cstdint>
#include <limits>
#include <optional>
#include <string>
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
  double scale = 1;        // image px per template px (a part seen larger is nearer the camera: pose.z says how high)
  double score = 0;        // 0..1
  int label = 0;           // part class (paper 002's labels); 0 when the method does not classify
  double confidence = 0;   // [0, 1]: the classifier's confidence in `label`; 0 without a classifier
};

// A part found but outside its job's limits (core/pose_limits.hpp): journalled, never
// delivered to a robot or the PLC.
struct RejectedPart {
  PartResult part;
  std::string why;  // "offset x 62.100 mm outside [-50, 50]"
};

struct CycleResult {
  std::uint32_t cycleId = 0;
  Status status = Status::Internal;
  int jobId = 0;
  TriggerSource trigger = TriggerSource::Modbus;
  std::uint64_t frameId = 0;   // camera frame (GVSP block) id, 0 when no frame
  // Eye-in-hand snapshot: T_base_flange the robot sent with its trigger (mm + quaternion).
  std::optional<Pose> flange;
  std::vector<PartResult> parts;  // best first; only parts within the job's limits
  std::vector<RejectedPart> rejected;  // outside the limits; status -9 when `parts` is empty
  Pose reference;              // the job's taught reference (base frame) the offsets are from
  // The calibration drift monitor (daemon/drift_monitor.hpp), when the cell has one: the
  // fixed fiducial's residual in this frame (mapped minus stored position, mm; NaN when it
  // was not seen) and the alarm state after this frame.
  bool driftMonitored = false;
  double driftMm = std::numeric_limits<double>::quiet_NaN();
  bool driftAlarm = false;
  double grabMs = 0, locateMs = 0, totalMs = 0;
  std::chrono::system_clock::time_point triggerTime;
  // The frame went to the image archive (vgrd's daemon/image_archive.hpp): the journal line
  // names its file ("archive"), derived from cycleId and triggerTime.
  bool archived = false;
};

}  // namespace vgr
