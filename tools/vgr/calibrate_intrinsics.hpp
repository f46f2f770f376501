// `vgr calibrate intrinsics`: camera matrix and distortion from plate images
// (docs/calibration.md).
// Returns the process exit code: 0 ok, 2 bad input (message on stderr naming file / view / key).
#pragma once

#include <string>

#include "tools/vgr/calibrate_common.hpp"
#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct CalibIntrinsicsOptions {
  std::string images;  // glob, e.g. "/data/calib/*.png"
  CalibPatternOptions pattern;
  std::string out = "intrinsics.yaml";
  bool noTangential = false;  // hold p1 = p2 = 0 (CALIB_ZERO_TANGENT_DIST)
  bool json = false;
};

int runCalibrateIntrinsics(const CalibIntrinsicsOptions& o);

class CalibrateIntrinsicsCommand final : public OptionsSubcommand<CalibIntrinsicsOptions, runCalibrateIntrinsics> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
