// Cycle orchestration. One cycle is four calls into four layers:
//   grab    CameraWorker::grab()             drivers: the frame, within the deadline
//   locate  vision::Locator::locate()        vision/locate: detections in pixels
//   map     vision::partPoses()              vision/calib: poses in the robot base frame;
//           parts outside the job's limits (core/pose_limits.hpp) are set apart
//           (CycleResult::rejected, never delivered; -9 OFFSET_OUT_OF_LIMITS when none is left)
//   deliver CycleSinks::onResult()           daemon: PLC links, robots, journal
// With a drift monitor (cell.yaml calibration.drift) every grabbed frame also measures the
// fixed fiducial (daemon/drift_monitor.hpp).
// Every job is a Locator (a taught job's method from its folder; an untaught job the
// blob-moments locator from its cell-config keys), built at start; the pixel -> robot
// mapping is the one the cell config selects (daemon/cell_mapping.hpp).
// A 3D job (kind: 3d, a depth camera; docs/3d.md "vgrd") is a vision::cloud::Locator3d:
//   grab    the depth frame (float mm + the intrinsics the camera sent with it)
//   locate  Locator3d::locate() -> T_cam_grasp per part, outcome Found / NotFound (1) /
//           RetryFromNewViewpoint (4 RETRY_NEW_VIEWPOINT)
//   map     T_base_grasp = T_base_cam * T_cam_grasp, T_base_cam from the hand-eye file
//           (eye-in-hand: T_base_flange of the trigger * T_flange_cam), all six DoF; limits
//   deliver as for 2D; the sinks get the depth frame with its intrinsics and T_base_cam
//           (daemon/cycle_image.hpp): the page draws it, the image archive keeps gray frames only
// Triggers come from any thread through submit() (non-blocking, bounded queue); cycles run
// one at a time on the cycle thread; every accepted trigger produces exactly one
// CycleResult, by its deadline (an error status when the camera or vision cannot finish).
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <functional>
#include <map>
#include <memory>
#include <mutex>
#include <optional>
#include <string>
#include <thread>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "core/result.hpp"
#include "core/heartbeat.hpp"
#include "daemon/cell_mapping.hpp"
#include "daemon/cycle_image.hpp"
#include "drivers/camera_worker.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/cloud/locator3d.hpp"
#include "vision/locate/locator.hpp"
#include "vision/part_poses.hpp"

namespace vgr::daemon {

class DriftMonitor;

struct CycleSinks {
  // Cycle thread, when a cycle starts (the result is pending). Must not block.
  std::function<void(std::uint32_t cycleId, int jobId)> onStarted;
  // Cycle thread, once per accepted trigger. Must not block for long. `image`: the frame the
  // locator was given (daemon/cycle_image.hpp: 8-bit gray, or a 3D cycle's depth frame with
  // its intrinsics and camera pose; valid during the call only; empty when the cycle had no
  // frame); a sink may set r.archived (the image archive took the frame).
  std::function<void(CycleResult& r, const CycleImage& image)> onResult;
};

// The cycle id after `last` (0: none yet): last + 1, wrapping to 1 after kMaxCycleId
// (ids stay below 2^23, core/cycle.hpp).
std::uint32_t firstCycleIdAfter(std::uint32_t last);

class CycleRunner {
 public:
  static constexpr std::size_t kQueueCapacity = 4;

  CycleRunner(const config::CellConfig& cell, drivers::CameraWorker& camera, CycleSinks sinks);
  ~CycleRunner();

  // Start-up, before start(): builds every job's locator (a folder: job.yaml, template,
  // vision::makeLocator; no folder: the untaught moments locator) and warms it up once; a 3D
  // job's Locator3d (makeJobLocator3d: its model's features, no warm-up image).
  // Errors name the job folder's file and what is wrong.
  Result<void> prepareJobs();
  void start();
  void stop();  // finishes the running cycle, answers queued triggers with INTERNAL, joins

  // Any thread, non-blocking. Returns the new cycle id, or 0 when the queue is full (the
  // caller reports BUSY_OVERRUN). jobId 0 means the cell's first job. `flange`: the robot's
  // T_base_flange at an eye-in-hand snapshot (an eye-in-hand cell maps only with one; a
  // fixed camera ignores it).
  std::uint32_t submit(int jobId, TriggerSource source, const std::optional<Pose>& flange = std::nullopt);

  std::uint64_t overruns() const { return overruns_.load(); }
  // The drift monitor (calibration.drift), null without one; its snapshot() is thread-safe.
  const DriftMonitor* driftMonitor() const { return drift_.get(); }

  // The job a trigger with job 0 runs (Modbus JOB_ID 0, SIGUSR1, the page's trigger): the
  // cell's first job until the operator switches it (the page's "switch job"). Any thread.
  // Robots keep their own `job` (cell config) until they send JOB,<n>. Error: JOB_NOT_FOUND.
  Result<void> setDefaultJob(int jobId);
  int defaultJob() const { return defaultJob_.load(); }
  // Beaten by the cycle thread at least every kIdleBeat while idle and after every cycle;
  // read by vgrd's watchdog (daemon/watchdog.hpp). A cycle ends by its deadline (the grab
  // waits at most until then; a locator overrunning it is -5 but still has to return), so
  // the longest legitimate silence is one deadline: stallLimit() = cycle_deadline_ms + 2 s.
  const Heartbeat& heartbeat() const { return heartbeat_; }
  std::chrono::milliseconds stallLimit() const;
  static constexpr std::chrono::milliseconds kIdleBeat{500};

  // Before start(): the id of the first cycle (vgrd: firstCycleIdAfter(the journal's last
  // cycle), so ids do not repeat across restarts). Outside [1, kMaxCycleId]: 1.
  void setFirstCycleId(std::uint32_t id);

 private:
  struct Trigger {
    std::uint32_t cycleId;
    int jobId;
    TriggerSource source;
    std::optional<Pose> flange;
    std::chrono::steady_clock::time_point at;
    std::chrono::system_clock::time_point wallAt;
  };
  void run();
  // shown: set to the image the locator was given (a view of frame_ or the converted
  // Mono16 frame; a 3D job's depth frame with its intrinsics and T_base_cam) once a frame of
  // the right size was grabbed; left empty otherwise.
  CycleResult runCycle(const Trigger& t, CycleImage& shown);
  struct PreparedJob;
  // The rest of runCycle for a 3D job, after the job and calibration checks.
  CycleResult runCycle3d(const Trigger& t, PreparedJob& job, CycleResult r, CycleImage& shown);
  // How both cycles start: an eye-in-hand camera needs the trigger's flange pose, then the
  // grab into frame_ before the deadline's processing reserve (r gets grabMs, frameId).
  // Errors: BadArgument (no flange pose), CameraError (the grab's reason).
  Result<void> grabFrame(const Trigger& t, bool eyeInHand, std::chrono::steady_clock::time_point deadline, CycleResult& r);
  // r ended with `status` (no parts), its time taken, `why` logged as a warning.
  static CycleResult ended(CycleResult r, const Trigger& t, Status status, const std::string& why);

  const config::CellConfig& cell_;
  drivers::CameraWorker& camera_;
  CycleSinks sinks_;
  // The cell's pixel -> robot mapping, or why it cannot be had (then every job answers
  // NOT_CALIBRATED with that message).
  std::unique_ptr<vision::calib::PixelMapping> mapping_;
  // A depth camera's cell maps 3D poses with this instead (mapping_ stays null).
  std::optional<DepthCellFrame> depthFrame_;
  std::string calibrationError_;
  std::unique_ptr<DriftMonitor> drift_;  // null without calibration.drift
  std::thread thread_;
  std::mutex mutex_;
  std::condition_variable cv_;
  std::deque<Trigger> queue_;
  bool stopping_ = false;
  std::uint32_t nextCycleId_ = 1;
  std::atomic<std::uint64_t> overruns_{0};
  std::atomic<int> defaultJob_;
  Heartbeat heartbeat_;
  drivers::Frame frame_;
  struct PreparedJob {
    std::unique_ptr<vision::Locator> locator;            // a 2D job
    std::unique_ptr<vision::cloud::Locator3d> locator3d; // a 3D job (job.depth)
    vision::PartPoseRules rules;
    JobLimits limits;
  };
  std::map<int, PreparedJob> jobs_;  // by job id, every configured job (prepareJobs)
};

}  // namespace vgr::daemon
