// `vgr calibrate verify`: does the calibration still hold? Measures the check targets of
// the cell's check file (vision/calib/check_file.hpp: a fixed fiducial and/or a check part
// of a cell job lying at its place) in frames of the cell's camera (or --image files)
// through the cell's mapping, exactly as vgrd would, and compares them with their stored
// positions: pass when every target is within the file's tolerance (docs/calibration.md,
// "Checking a calibration").
// --store measures the targets the options name (--fiducial-window, --part-job) and writes
// the check file: do it right after a calibration known to be good.
// Exit: 0 every check passes (or stored), 1 a check fails or a target is not seen (or the
// calibration does not load), 2 bad input (config, check file, options, images).
#pragma once

#include <string>
#include <vector>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct CalibVerifyOptions {
  std::string config;               // the cell config (required)
  std::vector<std::string> images;  // frames to measure in (files or globs); none = grab from the camera
  int frames = 3;                   // frames to grab; the median of the measurements counts
  std::string check;                // the check file; default: the config's calibration.check
  bool store = false;               // measure and write the check file
  std::string fiducialWindow;       // --store: "x,y,width,height" px, where the fiducial is searched
  double fiducialHeightMm = 0;      // --store: its height above the work plane, mm
  bool dark = false;                // --store: a dark mark on a bright ground
  int partJob = 0;                  // --store: a check part of this job id (0 = none)
  double toleranceMm = 0;           // > 0: overrides the file's (verify) / is stored (store; default 0.2)
  double toleranceDeg = 0;          // > 0: likewise (default 0.1)
  bool json = false;
};

int runCalibrateVerify(const CalibVerifyOptions& o);

class CalibrateVerifyCommand final : public OptionsSubcommand<CalibVerifyOptions, runCalibrateVerify> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
