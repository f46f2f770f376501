// `vgr calibrate plane`: the work plane from a plate lying on the conveyor or from
// robot-touched points (docs/calibration.md).
// Returns the process exit code: 0 ok, 2 bad input (message on stderr naming file / view / key).
#pragma once

#include <string>

#include "tools/vgr/calibrate_common.hpp"
#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct CalibPlaneOptions {
  std::string intrinsics, handeye;  // for --image: intrinsics.yaml and an eye-to-hand handeye.yaml
  std::string image;                // (a) a plate lying on the conveyor
  double thicknessMm = 0;           //     its thickness (the plane is moved down by it)
  std::string points;               // (b) robot-touched points, "x y z" in mm per line
  CalibPatternOptions pattern;
  std::string out = "plane.yaml";
  bool json = false;
};

int runCalibratePlane(const CalibPlaneOptions& o);

class CalibratePlaneCommand final : public OptionsSubcommand<CalibPlaneOptions, runCalibratePlane> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
