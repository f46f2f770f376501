#include "daemon/cycle_runner.hpp"

#include <cmath>
#include <numbers>
#include <optional>

#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "core/log.hpp"
#include "core/pose_limits.hpp"
#include "daemon/cell_mapping.hpp"
#include "daemon/drift_monitor.hpp"
#include "daemon/job_locator.hpp"
#include "vision/calib/check_file.hpp"
#include "vision/gray_image.hpp"

namespace vgr::daemon {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

namespace {

constexpr double kDegToRad = std::numbers::pi / 180.0;
// Time kept back from the cycle deadline for localization and publishing (ms); the config
// refuses deadlines that leave the camera less than config::kMinCameraTimeMs.
constexpr int kProcessingReserveMs = config::kProcessingReserveMs;

double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

// The size the locators are warmed up at (their first locate() sizes their buffers): the
// camera's ROI when configured, else the size the calibration was made for, else the
// pinhole model's nominal image (twice the principal point). A camera that delivers another
// size costs one slower first cycle, never a wrong answer.
struct WarmSize {
  int width, height;
  const char* source;
};
WarmSize warmUpSize(const config::CellConfig& cell, const vision::calib::PixelMapping* mapping) {
  if (cell.camera.roiWidth > 0 && cell.camera.roiHeight > 0) return {cell.camera.roiWidth, cell.camera.roiHeight, "camera ROI"};
  if (mapping)
    if (const auto size = mapping->imageSize()) return {size->width, size->height, "calibration"};
  return {static_cast<int>(std::lround(2 * (cell.model.cx + 0.5))), static_cast<int>(std::lround(2 * (cell.model.cy + 0.5))),
          "model principal point"};
}

// Parts outside the job's limits are set apart (journal only), keeping the order.
void setApartOutsideLimits(const JobLimits& limits, CycleResult& r) {
  if (limits.empty()) return;
  std::size_t kept = 0;
  for (std::size_t i = 0; i < r.parts.size(); ++i) {
    std::string why = limitViolation(limits, r.parts[i].pose, r.parts[i].offset);
    if (why.empty()) r.parts[kept++] = r.parts[i];
    else r.rejected.push_back({r.parts[i], std::move(why)});
  }
  r.parts.resize(kept);
}

}  // namespace

CycleRunner::CycleRunner(const config::CellConfig& cell, drivers::CameraWorker& camera, CycleSinks sinks)
    : cell_(cell), camera_(camera), sinks_(std::move(sinks)), defaultJob_(cell.jobs.empty() ? 0 : cell.jobs.front().id) {
  if (cell.camera.depth()) {
    // A depth camera's cell: 3D jobs only (the config refuses 2D ones), mapped by the hand-eye.
    auto f = makeDepthCellFrame(cell);
    if (f) {
      depthFrame_ = std::move(*f);
      log::info("cycle", "depth camera: 3D poses through {}", depthFrame_->description);
    } else {
      calibrationError_ = f.error().message;
      log::error("cycle", "NOT_CALIBRATED: {}", calibrationError_);
    }
    return;
  }
  auto m = makeCellMapping(cell);
  if (m) {
    mapping_ = std::move(*m);
    log::info("cycle", "mapping with {}", mapping_->describe());
    if (cell.calibration.enabled && cell.calibration.multiHeight.empty())
      log::info("cycle", "mapping with calibration files {}, {}, {}", cell.calibration.intrinsics, cell.calibration.handeye,
                cell.calibration.plane);
  } else {
    calibrationError_ = m.error().message;
    log::error("cycle", "NOT_CALIBRATED: {}", calibrationError_);
  }
  if (mapping_ && cell.calibration.drift.enabled) {
    // A drift monitor the config asks for but that cannot run leaves the calibration
    // unchecked: every job answers NOT_CALIBRATED, as for a missing calibration file.
    auto check = vision::calib::readCheckFile(cell.calibration.check);
    if (check && !check->fiducial.present) check = fail(Status::NotCalibrated, cell.calibration.check + ": no 'fiducial' to monitor");
    if (check) {
      drift_ = std::make_unique<DriftMonitor>(cell.calibration.drift, check->fiducial);
      log::info("cycle", "drift monitor: {}", drift_->describe());
    } else {
      calibrationError_ = "drift monitor: " + check.error().message;
      mapping_.reset();
      log::error("cycle", "NOT_CALIBRATED: {}", calibrationError_);
    }
  }
}

CycleRunner::~CycleRunner() { stop(); }

Result<void> CycleRunner::prepareJobs() {
  const WarmSize warmSize = warmUpSize(cell_, mapping_.get());  // 2D jobs
  for (const auto& job : cell_.jobs) {
    PreparedJob prepared;
    prepared.rules.heightMm = job.partHeightMm;
    prepared.rules.angleOffsetDeg = job.angleOffsetDeg;
    prepared.rules.reference =
        poseFromXyzRz(job.reference.x, job.reference.y, job.reference.z, job.reference.rzDeg * kDegToRad);
    prepared.limits = job.limits;
    if (job.depth) {
      // The model's features are computed here, not in the first cycle.
      const auto buildStart = Clock::now();
      auto loc3d = makeJobLocator3d(job);
      if (!loc3d) return std::unexpected(loc3d.error());
      prepared.locator3d = std::move(*loc3d);
      const Search3dParams& p = prepared.locator3d->params();
      log::info("cycle", "job {}: 3D model from {} ({:.0f} ms; voxel {} mm, n_R {}, f_l {}, f_h {}, {} thread(s))", job.id,
                job.folder, msSince(buildStart), p.voxelMm, p.nRotations, p.fLow, p.fHigh, p.threads);
      jobs_[job.id] = std::move(prepared);
      continue;
    }
    auto loc = makeJobLocator(job);
    if (!loc) return std::unexpected(loc.error());
    prepared.locator = std::move(*loc);
    // The first locate() sizes the method's buffers (the shape matcher: ~1 s at 2448x2048):
    // pay it now, not in the first cycle's deadline.
    const auto warmStart = Clock::now();
    const auto warm = prepared.locator->locate(cv::Mat(warmSize.height, warmSize.width, CV_8UC1, cv::Scalar(0)));
    if (job.folder.empty())
      log::info("cycle", "job {}: untaught moments (threshold {}, area {}..{} px²; warm-up at {}x{} from the {}: {:.0f} ms{})",
                job.id, job.threshold, job.minAreaPx, job.maxAreaPx, warmSize.width, warmSize.height, warmSize.source,
                msSince(warmStart), warm ? "" : ", " + warm.error().message);
    else
      log::info("cycle", "job {}: method {} from {} (warm-up at {}x{} from the {}: {:.0f} ms{})", job.id, job.method,
                job.folder, warmSize.width, warmSize.height, warmSize.source, msSince(warmStart),
                warm ? "" : ", " + warm.error().message);
    jobs_[job.id] = std::move(prepared);
  }
  return {};
}
void CycleRunner::start() {
  thread_ = std::thread([this] {
    nameThisThread("vgr-cycle");
    run();
  });
}

void CycleRunner::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

Result<void> CycleRunner::setDefaultJob(int jobId) {
  if (cell_.findJob(jobId) == nullptr) return fail(Status::JobNotFound, fmt::format("job {} is not configured", jobId));
  const int before = defaultJob_.exchange(jobId);
  if (before != jobId) log::info("cycle", "default job {} -> {} (JOB_ID 0, the operator's trigger)", before, jobId);
  return {};
}

std::chrono::milliseconds CycleRunner::stallLimit() const {
  return milliseconds(cell_.cycleDeadlineMs) + milliseconds(2000);
}

std::uint32_t firstCycleIdAfter(std::uint32_t last) { return last == 0 || last >= kMaxCycleId ? 1 : last + 1; }

void CycleRunner::setFirstCycleId(std::uint32_t id) {
  std::lock_guard lock(mutex_);
  nextCycleId_ = id == 0 || id > kMaxCycleId ? 1 : id;
}

std::uint32_t CycleRunner::submit(int jobId, TriggerSource source, const std::optional<Pose>& flange) {
  // JOB_ID 0 (a PLC that never wrote HR1, SIGUSR1, the page's trigger) runs the default job:
  // the cell's first, or the one the operator switched to (setDefaultJob).
  if (jobId == 0) jobId = defaultJob_.load();
  std::uint32_t id;
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || queue_.size() >= kQueueCapacity) {
      overruns_++;
      return 0;
    }
    id = nextCycleId_;
    nextCycleId_ = nextCycleId_ >= kMaxCycleId ? 1 : nextCycleId_ + 1;
    queue_.push_back({id, jobId, source, flange, Clock::now(), std::chrono::system_clock::now()});
  }
  cv_.notify_one();
  return id;
}

void CycleRunner::run() {
  for (;;) {
    Trigger t;
    {
      std::unique_lock lock(mutex_);
      // Bounded waits, a beat at each: an idle cycle thread is alive (daemon/watchdog.hpp).
      heartbeat_.beat();
      while (!cv_.wait_for(lock, kIdleBeat, [this] { return stopping_ || !queue_.empty(); })) heartbeat_.beat();
      heartbeat_.beat();
      if (queue_.empty()) return;  // stopping with nothing left
      t = queue_.front();
      queue_.pop_front();
      if (stopping_) {
        // Shutting down: still answer every accepted trigger.
        CycleResult r;
        r.cycleId = t.cycleId;
        r.jobId = t.jobId;
        r.status = Status::Internal;
        r.triggerTime = t.wallAt;
        lock.unlock();
        if (sinks_.onResult) sinks_.onResult(r, CycleImage{});
        continue;
      }
    }
    if (sinks_.onStarted) sinks_.onStarted(t.cycleId, t.jobId);
    CycleImage shown;
    CycleResult r = runCycle(t, shown);
    if (sinks_.onResult) sinks_.onResult(r, shown);
  }
}

CycleResult CycleRunner::ended(CycleResult r, const Trigger& t, Status status, const std::string& why) {
  r.status = status;
  r.parts.clear();
  r.rejected.clear();
  r.totalMs = msSince(t.at);
  log::warn("cycle", "cycle {}: {}", t.cycleId, why);
  return r;
}

Result<void> CycleRunner::grabFrame(const Trigger& t, bool eyeInHand, Clock::time_point deadline, CycleResult& r) {
  if (eyeInHand && !t.flange)
    return fail(Status::BadArgument, fmt::format("job {}: the camera is on the flange (eye-in-hand) and this {} trigger "
                                                 "carries no flange pose; a robot sends TRIG,<job>,<pose>",
                                                 t.jobId, triggerSourceName(t.source)));
  const auto grabStart = Clock::now();
  auto g = camera_.grab(frame_, deadline - milliseconds(kProcessingReserveMs));
  r.grabMs = msSince(grabStart);
  if (!g) return fail(Status::CameraError, g.error().message);
  r.frameId = frame_.frameId;
  return {};
}

CycleResult CycleRunner::runCycle3d(const Trigger& t, PreparedJob& job, CycleResult r, CycleImage& shown) {
  const auto deadline = t.at + milliseconds(cell_.cycleDeadlineMs);
  auto end = [&](Status status, const std::string& why) { return ended(std::move(r), t, status, why); };
  if (!depthFrame_)
    return end(Status::BadArgument, fmt::format("job {} is a 3D job and camera '{}' is a 2D camera", t.jobId, cell_.camera.name));
  // 1. grab (the camera on the flange: the pose of this image is the trigger's flange pose)
  if (auto g = grabFrame(t, depthFrame_->eyeInHand, deadline, r); !g) return end(g.error().code, g.error().message);
  if (!frame_.depth())
    return end(Status::BadArgument, fmt::format("job {} is a 3D job and camera '{}' delivered a 2D frame (not Coord3D_C16)",
                                                t.jobId, cell_.camera.name));
  DepthIntrinsics k = frame_.intrinsics;
  if (k.width == 0 && k.height == 0) {
    k.width = frame_.width;
    k.height = frame_.height;
  }
  if (!(k.fx > 0 && k.fy > 0) || k.width != frame_.width || k.height != frame_.height)
    return end(Status::CameraError, fmt::format("job {}: the depth frame's intrinsics (f {} / {} px, {}x{} px) do not fit "
                                                "its {}x{} px",
                                                t.jobId, k.fx, k.fy, k.width, k.height, frame_.width, frame_.height));
  // 2. locate (z in mm, 0 = no data; the Locator3d bounds its threads by the job's search.threads)
  const auto locateStart = Clock::now();
  const cv::Mat depth(frame_.height, frame_.width, CV_32FC1, frame_.data.data());
  const Pose baseFromCam = depthFrame_->baseFromCamera(t.flange ? &*t.flange : nullptr);
  shown.image = depth;  // the page draws it (a view: no copy here)
  shown.depth = true;
  shown.intrinsics = k;
  shown.baseFromCamera = baseFromCam;
  auto found = job.locator3d->locate(depth, k);
  r.locateMs = msSince(locateStart);
  if (!found) return end(found.error().code, fmt::format("job {}: {}", t.jobId, found.error().message));

  // 3. map: T_base_grasp = T_base_cam * T_cam_grasp, all six degrees of freedom.
  r.reference = job.rules.reference;
  r.parts.clear();
  for (const auto& part : found->parts) {
    PartResult p;
    p.pose = compose(baseFromCam, part.grasp);
    p.offset = compose(inverse(r.reference), p.pose);
    // Where the grasp point is in the depth image (x right, y down).
    if (part.grasp.z > 0) {
      p.uPx = k.cx + k.fx * part.grasp.x / part.grasp.z;
      p.vPx = k.cy + k.fy * part.grasp.y / part.grasp.z;
    }
    p.score = part.score;
    r.parts.push_back(p);
  }
  setApartOutsideLimits(job.limits, r);
  using vision::cloud::Outcome3d;
  r.status = !r.parts.empty()                                         ? Status::Ok
             : !r.rejected.empty()                                    ? Status::OffsetOutOfLimits
             : found->outcome == Outcome3d::RetryFromNewViewpoint     ? Status::RetryNewViewpoint
                                                                      : Status::NoPartFound;
  // Why a 3D cycle found nothing (one line per such cycle, as vgrd logs every status but OK;
  // a 3D cycle takes seconds, so this is no hot-path logging).
  if (r.status == Status::RetryNewViewpoint || r.status == Status::NoPartFound)
    log::info("cycle", "cycle {}: job {}: {} ({}; {} scene points, {} candidates, best other fitness {:.2f})", t.cycleId,
              t.jobId, vision::cloud::outcomeName(found->outcome), found->reason, found->scenePoints, found->candidates,
              found->bestOtherFitness);
  r.totalMs = msSince(t.at);
  if (Clock::now() > deadline)
    return end(Status::ProcessingTimeout, fmt::format("finished after its {} ms deadline", cell_.cycleDeadlineMs));
  return r;
}

CycleResult CycleRunner::runCycle(const Trigger& t, CycleImage& shown) {
  CycleResult r;
  r.cycleId = t.cycleId;
  r.jobId = t.jobId;
  r.trigger = t.source;
  r.flange = t.flange;
  r.triggerTime = t.wallAt;
  const auto deadline = t.at + milliseconds(cell_.cycleDeadlineMs);
  auto end = [&](Status status, const std::string& why) { return ended(std::move(r), t, status, why); };

  const auto job = jobs_.find(t.jobId);
  if (job == jobs_.end()) return end(Status::JobNotFound, fmt::format("job {} is not configured", t.jobId));
  if (!mapping_ && !depthFrame_)
    return end(Status::NotCalibrated, fmt::format("job {}: NOT_CALIBRATED: {}", t.jobId, calibrationError_));
  if (job->second.locator3d) return runCycle3d(t, job->second, std::move(r), shown);
  if (!mapping_)  // a 2D job on a depth camera's cell (the config refuses it; a safety net)
    return end(Status::BadArgument, fmt::format("job {}: a 2D method on a depth camera's cell", t.jobId));
  // 1. grab. An eye-in-hand camera moves with the robot: without the flange pose of this
  // image there is no mapping (a PLC or operator trigger, or a robot's TRIG without its pose).
  if (auto g = grabFrame(t, mapping_->eyeInHand() != nullptr, deadline, r); !g) return end(g.error().code, g.error().message);
  // A depth frame is no image for a 2D method (the camera was set to Coord3D_C16).
  if (frame_.depth())
    return end(Status::BadArgument, fmt::format("job {}: a 2D method cannot locate in the depth frames of this camera "
                                                "(pixel format Coord3D_C16)",
                                                t.jobId));
  if (const auto size = mapping_->imageSize(); size && (frame_.width != size->width || frame_.height != size->height))
    return end(Status::NotCalibrated, fmt::format("NOT_CALIBRATED: the calibration is for {}x{} px, the camera delivers {}x{} px",
                                                  size->width, size->height, frame_.width, frame_.height));

  // 2. locate
  const auto locateStart = Clock::now();
  cv::Mat image(frame_.height, frame_.width, CV_8UC1, frame_.data.data());
  if (frame_.pixel == drivers::PixelType::Mono16) {
    // The locator works on 8-bit gray: keep the top 8 of the camera's significant bits, the
    // one conversion the offline tools use too (vision/gray_image.hpp).
    thread_local cv::Mat gray8;  // cycle thread; reused between cycles
    const cv::Mat wide(frame_.height, frame_.width, CV_16UC1, frame_.data.data());
    vision::toGray8(wide, frame_.bitDepth, gray8);
    image = gray8;
  }
  shown.image = image;
  // Eye-in-hand: the camera was where the flange was for this image (checked above).
  std::optional<vision::calib::SnapshotMapping> snapshot;
  if (const auto* eyeInHand = mapping_->eyeInHand()) snapshot.emplace(*eyeInHand, *t.flange);
  const vision::calib::PixelMapping& mapping = snapshot ? *snapshot : *mapping_;
  if (drift_) {
    drift_->measure(image, mapping, r);
    if (r.driftAlarm && cell_.calibration.drift.refuse)
      return end(Status::NotCalibrated, "NOT_CALIBRATED: calibration drift alarm (on_alarm: refuse): " + drift_->reason());
  }
  auto found = job->second.locator->locate(image);
  r.locateMs = msSince(locateStart);
  if (!found) return end(found.error().code, found.error().message);

  // 3. map (eye-in-hand: through the snapshot's mapping)
  r.reference = job->second.rules.reference;
  r.parts = vision::partPoses(found->parts, mapping, job->second.rules);
  setApartOutsideLimits(job->second.limits, r);
  r.status = !r.parts.empty() ? Status::Ok : r.rejected.empty() ? Status::NoPartFound : Status::OffsetOutOfLimits;
  if (r.status == Status::OffsetOutOfLimits)
    log::warn("cycle", "cycle {}: OFFSET_OUT_OF_LIMITS: {} part(s) found, none within job {}'s limits ({})", t.cycleId,
              r.rejected.size(), t.jobId, r.rejected.front().why);
  r.totalMs = msSince(t.at);
  if (Clock::now() > deadline)
    return end(Status::ProcessingTimeout, fmt::format("finished after its {} ms deadline", cell_.cycleDeadlineMs));
  // 4. deliver: the caller hands r to the sinks.
  return r;
}

}  // namespace vgr::daemon
