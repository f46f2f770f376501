#include <cstring>

#include "config/cell_config.hpp"
#include "drivers/aravis_camera.hpp"
#include "drivers/camera.hpp"
#include "drivers/replay_camera.hpp"

namespace vgr::drivers {
namespace {

struct CameraDriver {
  const char* name;
  std::unique_ptr<Camera> (*make)(const config::CameraConfig&);
};

// Every camera driver, by the name the cell config uses.
constexpr CameraDriver kCameraDrivers[] = {
    {"aravis", &makeAravisCamera},
    {"replay", &makeReplayCamera},
};

}  // namespace

const char* frameStatusName(FrameStatus s) {
  switch (s) {
    case FrameStatus::Ok: return "ok";
    case FrameStatus::Timeout: return "timeout";
    case FrameStatus::Incomplete: return "incomplete";
    case FrameStatus::Underrun: return "underrun";
    case FrameStatus::Disconnected: return "disconnected";
    case FrameStatus::IllegalState: return "illegal_state";
    case FrameStatus::EndOfStream: return "end_of_stream";
    case FrameStatus::Failed: return "failed";
  }
  return "failed";
}

Result<std::unique_ptr<Camera>> makeCamera(const config::CameraConfig& c) {
  for (const auto& d : kCameraDrivers)
    if (c.driver == d.name) return d.make(c);
  return fail(Status::BadArgument, "camera '" + c.name + "': unknown driver '" + c.driver + "'");
}

}  // namespace vgr::drivers
