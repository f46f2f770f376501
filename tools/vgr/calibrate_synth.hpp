// `vgr calibrate synth`: synthetic calibration data sets with ground truth
// (docs/calibration.md).
// Returns the process exit code: 0 ok, 2 bad input (message on stderr naming file / view / key).
#pragma once

#include <cstdint>
#include <string>

#include "tools/vgr/calibrate_common.hpp"
#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct CalibSynthOptions {
  std::string kind = "intrinsics";     // intrinsics | handeye | handeye-cloud | cell
  std::string cellConfig;              // cell: the cell config whose camera to use (default: the embedded sim cell)
  std::string out;                     // folder (created)
  std::string configuration = "eye-to-hand";
  std::string poseFormat = "abb";      // abb | fanuc | ur
  CalibPatternOptions pattern;
  int views = 20;
  std::uint64_t seed = 1;
  double robotNoiseMm = 0.05, robotNoiseDeg = 0.01;
  double maxTiltDeg = 40, distanceMm = 420;
  double partialShare = 0;             // share of views with the plate partly outside the image (charuco)
  double depthNoiseMm = 0.3;           // handeye-cloud: Gaussian depth noise per pixel, mm
  double depthFocalPx = 0;             // handeye-cloud: the depth camera's focal length, px (0: sim::defaultDepthCamera's)
};

int runCalibrateSynth(const CalibSynthOptions& o);

class CalibrateSynthCommand final : public OptionsSubcommand<CalibSynthOptions, runCalibrateSynth> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
