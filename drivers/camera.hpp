// The small camera interface the daemon sees (STYLE.md rule 2), with an explicit
// lifecycle Closed -> Open -> Streaming whose illegal transitions return an error.
// A Camera instance is used from ONE thread (the daemon's acquisition thread); it may block
// (GVCP commands to a dead camera block ~2.5 s), so never call it from the I/O thread.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/result.hpp"

namespace vgr::config {
struct CameraConfig;
}

namespace vgr::drivers {

enum class CameraState { Closed, Open, Streaming };

// Why one acquisition failed: data, not an exception (as Aravis' buffer status).
enum class FrameStatus { Ok, Timeout, Incomplete, Disconnected, Failed };
const char* frameStatusName(FrameStatus s);

struct Frame {
  std::vector<std::uint8_t> data;  // Mono8, row-major, stride == width; reused between frames
  int width = 0, height = 0;       // px
  std::uint64_t frameId = 0;       // device frame (GVSP block) id
  std::uint64_t deviceTimestampNs = 0;
  std::uint64_t hostTimestampNs = 0;
};

class Camera {
 public:
  virtual ~Camera() = default;
  virtual Result<void> open() = 0;    // Closed -> Open; applies the configured features
  virtual void close() = 0;           // any -> Closed; never fails
  virtual Result<void> start() = 0;   // Open -> Streaming (buffers queued, acquisition started)
  virtual void stop() = 0;            // Streaming -> Open
  // Streaming only: a software trigger, then wait up to `timeout` for the frame. On failure
  // the error's code is Status::CameraError and `lastFrameStatus()` says why.
  virtual Result<void> triggerAndWait(Frame& out, std::chrono::milliseconds timeout) = 0;
  virtual CameraState state() const = 0;
  virtual FrameStatus lastFrameStatus() const = 0;
  // True once the device reported its control channel lost (Aravis "control-lost").
  virtual bool controlLost() const = 0;
  virtual std::string describe() const = 0;  // "aravis 127.0.0.1 (VGR-SIM-0)" for messages
};

// The driver registry: one explicit table (STYLE.md rule 3). Unknown names are an error.
Result<std::unique_ptr<Camera>> makeCamera(const config::CameraConfig& config);

}  // namespace vgr::drivers
