// The acquisition thread of one camera. It owns the Camera (whose calls may block for
// seconds when the device is gone), reconnects with back-off when the device drops out,
// and hands frames to the cycle thread. grab() never waits past its deadline: a camera
// that hangs costs one cycle a CAMERA_ERROR, not a hung trigger.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "config/cell_config.hpp"
#include "core/result.hpp"
#include "drivers/camera.hpp"

namespace vgr::daemon {

struct CameraCounters {
  std::uint64_t completed = 0, failed = 0, timeouts = 0, reconnects = 0, abandoned = 0;
};

class CameraWorker {
 public:
  CameraWorker(config::CameraConfig config, std::unique_ptr<drivers::Camera> camera);
  ~CameraWorker();  // stops and joins

  void start();
  void stop();

  // Cycle thread. Triggers one frame and waits for it until `deadline`. On success the
  // frame is swapped into `out` (no copy, no allocation once warm).
  Result<void> grab(drivers::Frame& out, std::chrono::steady_clock::time_point deadline);

  // Any thread: true while the camera is open and streaming.
  bool streaming() const;
  // Blocks until the camera streams for the first time or `timeout` passes.
  bool waitStreaming(std::chrono::milliseconds timeout);
  CameraCounters counters() const;

 private:
  void run();
  bool connect();      // acquisition thread
  void disconnect();   // acquisition thread

  config::CameraConfig cfg_;
  std::unique_ptr<drivers::Camera> camera_;
  std::thread thread_;

  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool stopping_ = false;
  bool streaming_ = false;
  // One request slot: the cycle thread fills it, the acquisition thread serves it.
  std::uint64_t requestSeq_ = 0;    // last request made
  std::uint64_t servedSeq_ = 0;     // last request finished
  std::uint64_t abandonedSeq_ = 0;  // the requester gave up waiting for this one
  std::chrono::steady_clock::time_point requestDeadline_;
  Result<void> outcome_;
  drivers::Frame frame_;            // filled by the acquisition thread, swapped out by grab()
  CameraCounters counters_;
};

}  // namespace vgr::daemon
