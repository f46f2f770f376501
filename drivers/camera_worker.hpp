// The acquisition thread of one camera. It owns the Camera (whose calls may block for
// seconds when the device is gone), reconnects with back-off when the device drops out
// (re-applying every feature: Camera::open does), re-triggers lost frames within the
// caller's deadline (camera.retries), and hands frames to the cycle thread. grab() never
// waits past its deadline: a camera that hangs costs one cycle a CAMERA_ERROR, not a hung
// trigger.
#pragma once

#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <memory>
#include <mutex>
#include <string>
#include <thread>

#include "config/cell_config.hpp"
#include "core/heartbeat.hpp"
#include "core/result.hpp"
#include "drivers/camera.hpp"

namespace vgr::drivers {

struct CameraCounters {
  // Per grab() (one cycle): completed + failed + abandoned = grabs that reached the camera.
  std::uint64_t completed = 0, failed = 0, timeouts = 0, reconnects = 0, abandoned = 0;
  std::uint64_t incomplete = 0;  // failed grabs whose last attempt had missing packets
  std::uint64_t retries = 0;     // re-triggers after a lost frame
  std::uint64_t recovered = 0;   // grabs that got their frame on a re-trigger
  // From the driver (cumulative over reconnects).
  std::uint64_t underruns = 0, missingPackets = 0, resentPackets = 0;
};

class CameraWorker {
 public:
  CameraWorker(config::CameraConfig config, std::unique_ptr<Camera> camera);
  ~CameraWorker();  // stops and joins

  void start();
  void stop();  // joins the thread and logs the counters once

  // Cycle thread. Triggers one frame (re-triggering up to camera.retries times after a lost
  // frame while the deadline allows) and waits for it until `deadline`. On success the
  // frame is swapped into `out` (no copy, no allocation once warm). `status`, if given,
  // receives the typed outcome (Ok, Timeout, Incomplete, Disconnected, ...).
  Result<void> grab(Frame& out, std::chrono::steady_clock::time_point deadline,
                    FrameStatus* status = nullptr);

  // Any thread: true while the camera is open and streaming.
  bool streaming() const;
  // Blocks until the camera streams for the first time or `timeout` passes.
  bool waitStreaming(std::chrono::milliseconds timeout);
  CameraCounters counters() const;
  std::string describe() const { return describe_; }
  // Beaten by the acquisition thread at every turn of its loop (at most 200 ms apart while
  // idle, 500 ms during a back-off; a connect or a serve() in between blocks at most a few
  // GVCP timeouts); read by vgrd's watchdog (daemon/watchdog.hpp).
  const Heartbeat& heartbeat() const { return heartbeat_; }
  // One GVCP command to a dead device blocks ~2.5 s (PITFALLS.md), a connect or a serve()
  // a few of them: 20 s without a beat is a hung acquisition thread.
  static constexpr std::chrono::milliseconds kStallLimit{20000};

 private:
  void run();
  // Opens and starts the camera; the error says why not (a refused camera names the feature).
  Result<void> connect();  // acquisition thread
  void disconnect();   // acquisition thread
  void serve(std::uint64_t seq);  // acquisition thread: one request with its retries

  config::CameraConfig cfg_;
  std::unique_ptr<Camera> camera_;
  const std::string describe_;
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
  FrameStatus outcomeStatus_ = FrameStatus::Ok;
  Frame frame_;            // filled by the acquisition thread, swapped out by grab()
  CameraCounters counters_;
  int consecutiveTimeouts_ = 0;     // acquisition thread
  Heartbeat heartbeat_;
};

}  // namespace vgr::drivers
