// `vgr grab` (docs/cameras.md): the camera side of a cell, tried alone.
#pragma once

#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct GrabOptions {
  std::string camera;       // IPv4 address, serial number or DeviceUserID
  std::string configPath;   // cell config whose camera section gives the features (optional)
  int count = 10;           // triggers
  std::string trigger;      // software | hardware | free_run (default: the config's)
  std::string pixelFormat;  // overrides camera.pixel_format
  int packetSize = -1;      // overrides camera.packet_size
  int retries = -1;         // overrides camera.retries
  int timeoutMs = -1;       // overrides camera.timeout_ms
  int deadlineMs = 0;       // trigger -> frame deadline per trigger (default: the cell's cycle deadline)
  int intervalMs = 0;       // pause between triggers
  bool json = false;        // machine-readable output; the last line is the summary object
  std::string saveFolder;   // if set: every frame received is written there as frame_<device frame id>.png
};

// Triggers `count` frames through vgrd's CameraWorker (re-trigger policy and
// reconnect included) and reports frames received, typed errors and trigger->frame latency
// percentiles. Exit code: 0 when the run completed (errors are counted, not fatal), 1 when
// the camera cannot be opened (the message names the camera and the setting), 2 on bad input.
int runGrab(const GrabOptions& options);

class GrabCommand final : public OptionsSubcommand<GrabOptions, runGrab> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
