// `vgr locate`: runs a job's method on one image (docs/localization.md). With the job's
// calibration (a cell config's `model`) each part also gets robot coordinates (mm, deg).
// An eye-in-hand calibration maps only with the image's flange pose: --flange.
// Exit code 0 (parts or none), 1 when the method fails (status and error in the JSON),
// 2 on bad input (message on stderr). --overlay writes the picture vgrd's web page shows.
// A 3D job (docs/3d.md) on a 16-bit depth image: the camera from --camera or the image's
// data set (DIR/images/x.png -> DIR/camera.yaml); the outcome (found, not_found,
// retry_new_viewpoint) and each part's pose and grasp in the camera frame (mm, quaternion);
// exit 0 whatever the outcome, 2 on bad input.
#pragma once

#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct LocateOptions {
  std::string job, image, method;
  std::string flange;  // eye-in-hand: T_base_flange of the image, "x,y,z,qw,qx,qy,qz" (mm, unit quaternion)
  std::string overlay;  // PNG of the image with what was found drawn on it (vision/overlay.hpp); empty = none
  std::string camera;   // 3D job: the depth camera's camera.yaml
  bool json = false;
};

int runLocate(const LocateOptions& o);

class LocateCommand final : public OptionsSubcommand<LocateOptions, runLocate> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
