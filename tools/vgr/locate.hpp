// `vgr locate`: runs a job's method on one image (docs/localization.md). With the job's
// calibration (a cell config's `model`) each part also gets robot coordinates (mm, deg).
// An eye-in-hand calibration maps only with the image's flange pose: --flange.
// Exit code 0 (parts or none), 1 when the method fails (status and error in the JSON),
// 2 on bad input (message on stderr). --overlay writes the picture vgrd's web page shows.
#pragma once

#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct LocateOptions {
  std::string job, image, method;
  std::string flange;  // eye-in-hand: T_base_flange of the image, "x,y,z,qw,qx,qy,qz" (mm, unit quaternion)
  std::string overlay;  // PNG of the image with what was found drawn on it (vision/overlay.hpp); empty = none
  bool json = false;
};

int runLocate(const LocateOptions& o);

class LocateCommand final : public OptionsSubcommand<LocateOptions, runLocate> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
