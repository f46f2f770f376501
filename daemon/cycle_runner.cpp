#include "daemon/cycle_runner.hpp"

#include <cmath>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job.hpp"

#include "core/log.hpp"
#include "vision/locate/moments_locator.hpp"

namespace vgr::daemon {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

namespace {

constexpr double kDegToRad = M_PI / 180.0;
// Time kept back from the cycle deadline for localization and publishing (ms).
constexpr int kProcessingReserveMs = 150;

double msSince(Clock::time_point t) { return std::chrono::duration<double, std::milli>(Clock::now() - t).count(); }

vision::PinholePlaneModel modelFrom(const config::PlaneModelConfig& m) {
  return vision::PinholePlaneModel(m.fx, m.fy, m.cx, m.cy,
                                   vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg),
                                   m.planeZ);
}

}  // namespace

const char* triggerSourceName(TriggerSource s) {
  switch (s) {
    case TriggerSource::Modbus: return "modbus";
    case TriggerSource::Robot: return "robot";
    case TriggerSource::Operator: return "operator";
  }
  return "unknown";
}

CycleRunner::CycleRunner(const config::CellConfig& cell, drivers::CameraWorker& camera, CycleSinks sinks)
    : cell_(cell), camera_(camera), sinks_(std::move(sinks)), model_(modelFrom(cell.model)) {
  if (cell.calibration.enabled) {
    auto m = vision::calib::loadCellCalibration(cell.calibration.intrinsics, cell.calibration.handeye,
                                                cell.calibration.plane);
    if (m) {
      calibrated_ = *m;
      log::info("cycle", "mapping with calibration files {}, {}, {}", cell.calibration.intrinsics,
                cell.calibration.handeye, cell.calibration.plane);
    } else {
      calibrationError_ = m.error().message;
      log::error("cycle", "NOT_CALIBRATED: {}", calibrationError_);
    }
  }
}

CycleRunner::~CycleRunner() { stop(); }

Result<void> CycleRunner::prepareJobs() {
  for (const auto& job : cell_.jobs) {
    if (job.folder.empty()) continue;
    auto jf = config::loadJob(job.folder);
    if (!jf) return std::unexpected(jf.error());
    const cv::Mat templ = cv::imread(jf->templatePath(), cv::IMREAD_GRAYSCALE);
    if (templ.empty()) return fail(Status::BadArgument, jf->templatePath() + ": cannot read the template image");
    auto loc = vision::makeLocator(job.method, templ, jf->taught);
    if (!loc) return fail(loc.error().code, fmt::format("job {} ({}): {}", job.id, job.folder, loc.error().message));
    // The first locate() sizes the method's buffers (the shape matcher: ~1 s at 2448x2048):
    // pay it now, not in the first cycle's deadline. Size: the camera ROI when configured,
    // else the simulated sensor (a real sensor's full size is known only once it streams).
    const int w = cell_.camera.roiWidth > 0 ? cell_.camera.roiWidth : cell_.sim.width;
    const int h = cell_.camera.roiHeight > 0 ? cell_.camera.roiHeight : cell_.sim.height;
    const auto warmStart = Clock::now();
    const auto warm = (*loc)->locate(cv::Mat(h, w, CV_8UC1, cv::Scalar(0)));
    log::info("cycle", "job {}: method {} from {} (warm-up at {}x{}: {:.0f} ms{})", job.id, job.method, job.folder, w, h,
              msSince(warmStart), warm ? "" : ", " + warm.error().message);
    locators_[job.id] = std::move(*loc);
  }
  return {};
}

void CycleRunner::start() { thread_ = std::thread([this] { run(); }); }

void CycleRunner::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

std::uint32_t CycleRunner::submit(int jobId, TriggerSource source) {
  // JOB_ID 0 (a PLC that never wrote HR1) runs the cell's first job.
  if (jobId == 0 && !cell_.jobs.empty()) jobId = cell_.jobs.front().id;
  std::uint32_t id;
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || queue_.size() >= kQueueCapacity) {
      overruns_++;
      return 0;
    }
    id = nextCycleId_;
    nextCycleId_ = nextCycleId_ >= kMaxCycleId ? 1 : nextCycleId_ + 1;
    queue_.push_back({id, jobId, source, Clock::now(), std::chrono::system_clock::now()});
  }
  cv_.notify_one();
  return id;
}

void CycleRunner::run() {
  for (;;) {
    Trigger t;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [this] { return stopping_ || !queue_.empty(); });
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
        if (sinks_.onResult) sinks_.onResult(r);
        continue;
      }
    }
    if (sinks_.onStarted) sinks_.onStarted(t.cycleId, t.jobId);
    const CycleResult r = runCycle(t);
    if (sinks_.onResult) sinks_.onResult(r);
  }
}

CycleResult CycleRunner::runCycle(const Trigger& t) {
  CycleResult r;
  r.cycleId = t.cycleId;
  r.jobId = t.jobId;
  r.triggerTime = t.wallAt;
  const auto deadline = t.at + milliseconds(cell_.cycleDeadlineMs);

  const config::JobConfig* job = cell_.findJob(t.jobId);
  if (!job) {
    r.status = Status::JobNotFound;
    r.totalMs = msSince(t.at);
    log::warn("cycle", "cycle {}: job {} is not configured", t.cycleId, t.jobId);
    return r;
  }

  if (!calibrationError_.empty()) {
    r.status = Status::NotCalibrated;
    r.totalMs = msSince(t.at);
    log::warn("cycle", "cycle {}: job {}: NOT_CALIBRATED: {}", t.cycleId, t.jobId, calibrationError_);
    return r;
  }

  const auto grabStart = Clock::now();
  auto g = camera_.grab(frame_, deadline - milliseconds(kProcessingReserveMs));
  r.grabMs = msSince(grabStart);
  if (!g) {
    r.status = Status::CameraError;
    r.totalMs = msSince(t.at);
    log::warn("cycle", "cycle {}: {}", t.cycleId, g.error().message);
    return r;
  }
  r.frameId = frame_.frameId;

  const auto locateStart = Clock::now();
  cv::Mat image(frame_.height, frame_.width, CV_8UC1, frame_.data.data());
  if (frame_.pixel == drivers::PixelType::Mono16) {
    // The locator works on 8-bit gray: keep the top 8 of the camera's significant bits.
    thread_local cv::Mat gray8;  // cycle thread; reused between cycles
    const cv::Mat wide(frame_.height, frame_.width, CV_16UC1, frame_.data.data());
    wide.convertTo(gray8, CV_8UC1, 1.0 / (1 << (frame_.bitDepth - 8)));
    image = gray8;
  }
  Result<std::vector<vision::Detection>> found;
  if (const auto it = locators_.find(job->id); it != locators_.end()) {
    // A taught job (folder): its method, built at start (prepareJobs).
    auto out = it->second->locate(image);
    if (out) found = std::move(out->parts);
    else found = std::unexpected(out.error());
  } else {
    vision::MomentsParams params;
    params.threshold = job->threshold;
    params.minAreaPx = job->minAreaPx;
    params.maxAreaPx = job->maxAreaPx;
    found = vision::locateByMoments(image, params);
  }
  r.locateMs = msSince(locateStart);
  if (!found) {
    r.status = found.error().code;
    r.totalMs = msSince(t.at);
    log::warn("cycle", "cycle {}: {}", t.cycleId, found.error().message);
    return r;
  }

  if (calibrated_ && (frame_.width != calibrated_->camera().imageSize.width ||
                      frame_.height != calibrated_->camera().imageSize.height)) {
    r.status = Status::NotCalibrated;
    r.totalMs = msSince(t.at);
    log::warn("cycle", "cycle {}: NOT_CALIBRATED: {} is for {}x{} px, the camera delivers {}x{} px", t.cycleId,
              cell_.calibration.intrinsics, calibrated_->camera().imageSize.width,
              calibrated_->camera().imageSize.height, frame_.width, frame_.height);
    return r;
  }
  // Pixel -> base frame at the part height: the calibration files when configured, else
  // the config's `model` (the simulated cell's known camera).
  auto toPlane = [&](vision::PixelPoint px, double h) -> std::optional<Vec3> {
    return calibrated_ ? calibrated_->pixelToRobot(px, h) : model_.pixelToPlane(px, h);
  };
  const Pose reference = poseFromXyzRz(job->reference.x, job->reference.y, job->reference.z, job->reference.rzDeg * kDegToRad);
  for (const auto& d : *found) {
    // Grasp point and a point 20 px along the part's axis, both onto the plane at the
    // part's grasp height; the robot-frame angle is the direction between them.
    const double a = d.angleDeg * kDegToRad;
    const auto p = toPlane({d.u, d.v}, job->partHeightMm);
    const auto q = toPlane({d.u + 20 * std::cos(a), d.v - 20 * std::sin(a)}, job->partHeightMm);
    if (!p || !q) continue;
    const double rz = std::atan2(q->y - p->y, q->x - p->x) + job->angleOffsetDeg * kDegToRad;
    PartResult part;
    part.pose = poseFromXyzRz(p->x, p->y, p->z, std::remainder(rz, 2 * M_PI));
    part.offset = compose(inverse(reference), part.pose);
    part.uPx = d.u;
    part.vPx = d.v;
    part.angleImgDeg = d.angleDeg;
    part.score = d.score;
    r.parts.push_back(part);
  }
  r.status = r.parts.empty() ? Status::NoPartFound : Status::Ok;
  r.totalMs = msSince(t.at);
  if (Clock::now() > deadline) {
    log::warn("cycle", "cycle {}: finished after its {} ms deadline", t.cycleId, cell_.cycleDeadlineMs);
    r.status = Status::ProcessingTimeout;
    r.parts.clear();
  }
  return r;
}

}  // namespace vgr::daemon
