#include "drivers/camera_worker.hpp"

#include <algorithm>

#include "core/log.hpp"

namespace vgr::drivers {

using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

namespace {
// A re-trigger is only worth it with at least this much time left before the deadline.
constexpr milliseconds kMinAttempt(20);
}  // namespace

CameraWorker::CameraWorker(config::CameraConfig config, std::unique_ptr<Camera> camera)
    : cfg_(std::move(config)), camera_(std::move(camera)), describe_(camera_->describe()) {}

CameraWorker::~CameraWorker() { stop(); }

void CameraWorker::start() {
  stopping_ = false;
  thread_ = std::thread([this] {
    nameThisThread("vgr-camera");
    run();
  });
}

void CameraWorker::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (!thread_.joinable()) return;
  thread_.join();
  const auto c = counters();
  log::info("camera", "{}: {} frames, {} failed ({} timeouts, {} incomplete), {} re-triggers ({} recovered), "
            "{} reconnects, {} abandoned; packets missing {}, resent {}; underruns {}",
            describe_, c.completed, c.failed, c.timeouts, c.incomplete, c.retries, c.recovered, c.reconnects,
            c.abandoned, c.missingPackets, c.resentPackets, c.underruns);
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

Result<void> CameraWorker::grab(Frame& out, Clock::time_point deadline, FrameStatus* status) {
  auto setStatus = [&](FrameStatus s) {
    if (status) *status = s;
  };
  std::unique_lock lock(mutex_);
  if (!streaming_) {
    setStatus(FrameStatus::Disconnected);
    return fail(Status::CameraError, describe_ + ": not connected (reconnecting)");
  }
  if (servedSeq_ != requestSeq_) {
    setStatus(FrameStatus::Timeout);
    return fail(Status::CameraError, describe_ + ": still busy with an earlier trigger");
  }
  const std::uint64_t seq = ++requestSeq_;
  requestDeadline_ = deadline;
  cv_.notify_all();
  if (!cv_.wait_until(lock, deadline, [&] { return servedSeq_ >= seq || stopping_; })) {
    abandonedSeq_ = seq;
    counters_.abandoned++;
    setStatus(FrameStatus::Timeout);
    return fail(Status::CameraError, describe_ + ": no frame before the cycle deadline");
  }
  if (servedSeq_ < seq) {
    setStatus(FrameStatus::Failed);
    return fail(Status::CameraError, "camera worker stopping");
  }
  setStatus(outcomeStatus_);
  if (!outcome_) return std::unexpected(outcome_.error());
  std::swap(out, frame_);
  return {};
}

Result<void> CameraWorker::connect() {
  if (auto r = camera_->open(); !r) return r;
  if (auto r = camera_->start(); !r) {
    camera_->close();
    return r;
  }
  return {};
}

void CameraWorker::disconnect() {
  {
    std::lock_guard lock(mutex_);
    streaming_ = false;
  }
  camera_->close();  // may block on a dead GigE device: we are on our own thread
}

void CameraWorker::serve(std::uint64_t seq) {
  Clock::time_point deadline;
  {
    std::lock_guard lock(mutex_);
    deadline = requestDeadline_;
  }
  Frame& target = frame_;  // only this thread touches frame_ between swaps
  Result<void> r;
  FrameStatus st = FrameStatus::Ok;
  int attempt = 0;
  for (;;) {
    const auto left = std::chrono::duration_cast<milliseconds>(deadline - Clock::now());
    const milliseconds timeout = std::clamp(left, milliseconds(1), milliseconds(cfg_.timeoutMs));
    r = camera_->triggerAndWait(target, timeout);
    st = r ? FrameStatus::Ok : camera_->lastFrameStatus();
    consecutiveTimeouts_ = st == FrameStatus::Timeout ? consecutiveTimeouts_ + 1 : 0;
    // Re-trigger only lost frames (a device problem is not cured by asking again).
    if (r || attempt >= cfg_.retries || (st != FrameStatus::Timeout && st != FrameStatus::Incomplete)) break;
    if (deadline - Clock::now() < kMinAttempt) break;
    ++attempt;
    log::debug("camera", "{}: {}; re-trigger {} of {}", describe_, r.error().message, attempt, cfg_.retries);
    std::lock_guard lock(mutex_);
    counters_.retries++;
  }

  const CameraStats ds = camera_->stats();
  bool late;
  {
    std::lock_guard lock(mutex_);
    outcome_ = r;
    outcomeStatus_ = st;
    servedSeq_ = seq;
    late = abandonedSeq_ == seq;
    if (!late) {
      if (r) {
        counters_.completed++;
        if (attempt > 0) counters_.recovered++;
      } else {
        counters_.failed++;
        if (st == FrameStatus::Timeout) counters_.timeouts++;
        if (st == FrameStatus::Incomplete) counters_.incomplete++;
      }
    }
    counters_.underruns = ds.underruns;
    counters_.missingPackets = ds.missingPackets;
    counters_.resentPackets = ds.resentPackets;
  }
  cv_.notify_all();
  if (late) log::debug("camera", "{}: outcome for an abandoned trigger dropped", describe_);
  if (!r) {
    log::warn("camera", "{}", r.error().message);
    // A refused command or a lost control channel means the device is gone (or restarted);
    // in software-trigger mode, two triggers in a row without any frame likely too.
    const bool softwareStuck = cfg_.trigger == config::TriggerMode::Software && consecutiveTimeouts_ >= 2;
    if (st == FrameStatus::Disconnected || camera_->controlLost() || softwareStuck) {
      log::warn("camera", "{}: reconnecting", describe_);
      consecutiveTimeouts_ = 0;
      disconnect();
    }
  }
}

void CameraWorker::run() {
  int backoffMs = cfg_.reconnectMinMs;
  bool everConnected = false;
  bool reportedDown = false;
  std::string reportedWhy;  // the reason last logged at warn level
  for (;;) {
    heartbeat_.beat();  // every turn: waits are at most 200 ms or the back-off (daemon/watchdog.hpp)
    {
      std::lock_guard lock(mutex_);
      if (stopping_) break;
    }
    if (camera_->state() != CameraState::Streaming) {
      const auto t0 = Clock::now();
      const Result<void> up = connect();
      if (up) {
        {
          std::lock_guard lock(mutex_);
          streaming_ = true;
          if (everConnected) counters_.reconnects++;
        }
        cv_.notify_all();
        log::info("camera", "{}: {} ({} ms)", describe_, everConnected ? "reconnected" : "streaming",
                  std::chrono::duration_cast<milliseconds>(Clock::now() - t0).count());
        everConnected = true;
        reportedDown = false;
        reportedWhy.clear();
        backoffMs = cfg_.reconnectMinMs;
      } else {
        // Why, at warn level once per outage and again when the reason changes (a camera
        // refused for a feature it reports must say which: issue 14); repeats at debug.
        const std::string& why = up.error().message;
        if (!reportedDown || why != reportedWhy)
          log::warn("camera", "{}: cannot connect ({}); retrying with back-off up to {} ms", describe_, why, cfg_.reconnectMaxMs);
        else
          log::debug("camera", "{}", why);
        reportedDown = true;
        reportedWhy = why;
        // The back-off in slices, a beat at each (reconnect_max_ms may exceed the stall limit).
        const auto until = Clock::now() + milliseconds(backoffMs);
        std::unique_lock lock(mutex_);
        while (!stopping_ && Clock::now() < until) {
          cv_.wait_until(lock, std::min(until, Clock::now() + milliseconds(500)), [this] { return stopping_; });
          heartbeat_.beat();
        }
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
        log::warn("camera", "{}: control channel lost; reconnecting", describe_);
        disconnect();
      }
      continue;
    }
    const std::uint64_t seq = requestSeq_;
    lock.unlock();
    serve(seq);
  }
  disconnect();
}

}  // namespace vgr::drivers
