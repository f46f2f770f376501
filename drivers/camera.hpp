// The small camera interface the daemon sees (STYLE.md rule 2), with an explicit
// lifecycle Closed -> Open -> Streaming whose illegal transitions return an error.
// A Camera instance is used from ONE thread (the daemon's acquisition thread); it may block
// (GVCP commands to a dead camera block ~2.5 s), so never call it from the I/O thread.
// Every implementation passes tests/integration/camera_conformance_test.cpp.
#pragma once

#include <chrono>
#include <cstdint>
#include <memory>
#include <string>
#include <vector>

#include "core/depth.hpp"
#include "core/result.hpp"

namespace vgr::config {
struct CameraConfig;
}

namespace vgr::drivers {

enum class CameraState { Closed, Open, Streaming };

// Why one acquisition failed: data, not an exception (as Aravis' buffer status).
enum class FrameStatus {
  Ok,
  Timeout,       // no frame within the timeout (no trigger seen, or the whole frame vanished)
  Incomplete,    // a frame arrived with missing packets (GVSP loss; the camera did not resend)
  Underrun,      // the driver had no free buffer for the frame
  Disconnected,  // the device refused a command or its control channel is lost
  IllegalState,  // called in the wrong lifecycle state (a programming error)
  EndOfStream,   // replay camera: the folder is exhausted and looping is off
  Failed,        // anything else (unexpected pixel format or size, conversion failure)
};
// (A depth camera whose Scan3d unit or format the driver cannot use is refused by open(),
// with Status::CameraError and a line naming the feature: it never delivers a frame.)
const char* frameStatusName(FrameStatus s);  // "ok", "timeout", "incomplete", ...

// Pixel layout of Frame::data. Bayer sensors are converted to Mono8 by the driver; depth
// cameras (Coord3D_C16) deliver DepthMm: float32 z in mm, 0 = no data (core/depth.hpp).
enum class PixelType { Mono8, Mono16, DepthMm };

struct Frame {
  // Row-major, stride == width * bytesPerPixel(); Mono16 samples are host-endian uint16
  // holding `bitDepth` significant bits (10, 12 or 16); DepthMm samples are host float32 z in
  // mm (0 = no data): cv::Mat(height, width, CV_32FC1, data.data()). Reused between frames:
  // the vector never reallocates once warm.
  std::vector<std::uint8_t> data;
  int width = 0, height = 0;       // px
  PixelType pixel = PixelType::Mono8;
  int bitDepth = 8;                // significant bits per sample
  std::uint64_t frameId = 0;       // device frame (GVSP block) id; replay: 1-based image count
  std::uint64_t deviceTimestampNs = 0;  // camera clock, ns (0 when the device has none)
  std::uint64_t hostTimestampNs = 0;    // host wall clock (ns since the Unix epoch) at arrival
  DepthIntrinsics intrinsics;           // DepthMm only: the pinhole intrinsics of this image
  int bytesPerPixel() const { return pixel == PixelType::DepthMm ? 4 : pixel == PixelType::Mono16 ? 2 : 1; }
  bool depth() const { return pixel == PixelType::DepthMm; }
};

// Cumulative since construction (survives close/open), frames and GVSP packets.
struct CameraStats {
  std::uint64_t completed = 0;       // frames delivered to the caller
  std::uint64_t failed = 0;          // triggers that ended in an error status
  std::uint64_t timeouts = 0;        // ... of which FrameStatus::Timeout
  std::uint64_t incomplete = 0;      // ... of which FrameStatus::Incomplete
  std::uint64_t underruns = 0;       // frames the stream dropped for lack of a buffer
  std::uint64_t missingPackets = 0;  // GVSP packets never received
  std::uint64_t resentPackets = 0;   // GVSP packets recovered by resend requests
};

class Camera {
 public:
  virtual ~Camera() = default;
  virtual Result<void> open() = 0;    // Closed -> Open; applies the configured features
  virtual void close() = 0;           // any -> Closed; never fails
  virtual Result<void> start() = 0;   // Open -> Streaming (buffers queued, acquisition started)
  virtual void stop() = 0;            // Streaming -> Open
  // Streaming only. Software trigger: trigger, then wait up to `timeout` for that frame.
  // Hardware trigger: wait up to `timeout` for the next frame the line triggered (frames
  // that arrived up to `timeout` before the call count). Free-run: the first frame that
  // completes after the call (older frames are recycled: only the latest is kept).
  // On failure the error code is Status::CameraError (Status::Internal for an illegal
  // state) and `lastFrameStatus()` says why.
  virtual Result<void> triggerAndWait(Frame& out, std::chrono::milliseconds timeout) = 0;
  virtual CameraState state() const = 0;
  virtual FrameStatus lastFrameStatus() const = 0;
  // True once the device reported its control channel lost (Aravis "control-lost").
  virtual bool controlLost() const = 0;
  virtual CameraStats stats() const = 0;
  virtual std::string describe() const = 0;  // "camera 'cam0' (aravis 127.0.0.1, serial X)"
};

// The driver registry: one explicit table (STYLE.md rule 3). Unknown names are an error.
Result<std::unique_ptr<Camera>> makeCamera(const config::CameraConfig& config);

}  // namespace vgr::drivers
