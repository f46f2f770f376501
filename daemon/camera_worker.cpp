#include "daemon/camera_worker.hpp"

#include <algorithm>

#include "core/log.hpp"

namespace vgr::daemon {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

CameraWorker::CameraWorker(config::CameraConfig config, std::unique_ptr<drivers::Camera> camera)
    : cfg_(std::move(config)), camera_(std::move(camera)) {}

CameraWorker::~CameraWorker() { stop(); }

void CameraWorker::start() {
  stopping_ = false;
  thread_ = std::thread([this] { run(); });
}

void CameraWorker::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool CameraWorker::streaming() const {
  std::lock_guard lock(mutex_);
  return streaming_;
}

bool CameraWorker::waitStreaming(milliseconds timeout) {
  std::unique_lock lock(mutex_);
  return cv_.wait_for(lock, timeout, [this] { return streaming_ || stopping_; }) && streaming_;
}

CameraCounters CameraWorker::counters() const {
  std::lock_guard lock(mutex_);
  return counters_;
}

Result<void> CameraWorker::grab(drivers::Frame& out, Clock::time_point deadline) {
  std::unique_lock lock(mutex_);
  if (!streaming_) return fail(Status::CameraError, camera_->describe() + ": not connected (reconnecting)");
  if (servedSeq_ != requestSeq_) return fail(Status::CameraError, camera_->describe() + ": still busy with an earlier trigger");
  const std::uint64_t seq = ++requestSeq_;
  requestDeadline_ = deadline;
  cv_.notify_all();
  if (!cv_.wait_until(lock, deadline, [&] { return servedSeq_ >= seq || stopping_; })) {
    abandonedSeq_ = seq;
    counters_.abandoned++;
    return fail(Status::CameraError, camera_->describe() + ": no frame before the cycle deadline");
  }
  if (servedSeq_ < seq) return fail(Status::CameraError, "camera worker stopping");
  if (!outcome_) return std::unexpected(outcome_.error());
  std::swap(out, frame_);
  return {};
}

bool CameraWorker::connect() {
  if (auto r = camera_->open(); !r) {
    log::debug("camera", "{}", r.error().message);
    return false;
  }
  if (auto r = camera_->start(); !r) {
    log::debug("camera", "{}", r.error().message);
    camera_->close();
    return false;
  }
  return true;
}

void CameraWorker::disconnect() {
  {
    std::lock_guard lock(mutex_);
    streaming_ = false;
  }
  camera_->close();  // may block ~2.5 s on a dead GigE device: we are on our own thread
}

void CameraWorker::run() {
  int backoffMs = cfg_.reconnectMinMs;
  bool everConnected = false;
  bool reportedDown = false;
  int consecutiveFailures = 0;
  for (;;) {
    {
      std::lock_guard lock(mutex_);
      if (stopping_) break;
    }
    if (camera_->state() != drivers::CameraState::Streaming) {
      if (connect()) {
        {
          std::lock_guard lock(mutex_);
          streaming_ = true;
          if (everConnected) counters_.reconnects++;
        }
        cv_.notify_all();
        log::info("camera", "{}: {}", camera_->describe(), everConnected ? "reconnected" : "streaming");
        everConnected = true;
        reportedDown = false;
        backoffMs = cfg_.reconnectMinMs;
        consecutiveFailures = 0;
      } else {
        if (!reportedDown) log::warn("camera", "{}: cannot connect; retrying with back-off up to {} ms", camera_->describe(), cfg_.reconnectMaxMs);
        reportedDown = true;
        std::unique_lock lock(mutex_);
        cv_.wait_for(lock, milliseconds(backoffMs), [this] { return stopping_; });
        backoffMs = std::min(backoffMs * 2, cfg_.reconnectMaxMs);
        // A trigger that arrived meanwhile was already refused by grab().
        continue;
      }
    }

    // Wait for a request; wake regularly to notice a lost control channel.
    std::unique_lock lock(mutex_);
    cv_.wait_for(lock, milliseconds(200), [this] { return stopping_ || requestSeq_ != servedSeq_; });
    if (stopping_) break;
    if (requestSeq_ == servedSeq_) {
      lock.unlock();
      if (camera_->controlLost()) {
        log::warn("camera", "{}: control channel lost; reconnecting", camera_->describe());
        disconnect();
      }
      continue;
    }
    const std::uint64_t seq = requestSeq_;
    const auto left = std::chrono::duration_cast<milliseconds>(requestDeadline_ - Clock::now());
    lock.unlock();

    drivers::Frame& target = frame_;  // only this thread touches frame_ between swaps
    const milliseconds timeout = std::clamp(left, milliseconds(1), milliseconds(cfg_.timeoutMs));
    Result<void> r = camera_->triggerAndWait(target, timeout);

    lock.lock();
    outcome_ = r;
    servedSeq_ = seq;
    if (r) {
      counters_.completed++;
    } else {
      counters_.failed++;
      if (camera_->lastFrameStatus() == drivers::FrameStatus::Timeout) counters_.timeouts++;
    }
    const bool late = abandonedSeq_ == seq;
    lock.unlock();
    cv_.notify_all();
    if (late) log::debug("camera", "{}: frame for an abandoned trigger dropped", camera_->describe());

    if (r) {
      consecutiveFailures = 0;
    } else {
      ++consecutiveFailures;
      log::warn("camera", "{} ({})", r.error().message, drivers::frameStatusName(camera_->lastFrameStatus()));
      // A refused command means the device is gone; two lost frames in a row likely too.
      if (camera_->lastFrameStatus() == drivers::FrameStatus::Disconnected || camera_->controlLost() ||
          consecutiveFailures >= 2) {
        log::warn("camera", "{}: reconnecting", camera_->describe());
        disconnect();
      }
    }
  }
  disconnect();
}

}  // namespace vgr::daemon
