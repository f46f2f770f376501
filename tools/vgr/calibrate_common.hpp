// What the `vgr calibrate ...` subcommands share (docs/calibration.md): the calibration
// plate options (--pattern, --cols, --rows, --square, --marker, --dict), their check, and
// the stderr conventions: one progress line per image, "vgr calibrate: ..." on bad input.
#pragma once

#include <cstddef>
#include <string>

#include "core/result.hpp"
#include "vision/calib/intrinsics.hpp"

namespace CLI {
class App;
}

namespace vgr::tools {

struct CalibPatternOptions {
  std::string pattern = "chessboard";  // chessboard | circles | charuco
  int cols = 9, rows = 6;              // inner corners (chessboard, charuco) / circles per row, column
  double squareMm = 20;                // square size / circle spacing, mm
  double markerMm = 0;                 // charuco marker side, mm (0: 0.75 x square)
  std::string dictionary = "DICT_5X5_100";  // charuco ArUco dictionary
};

// Adds the plate options to a calibrate subcommand.
void addPatternOptions(CLI::App& c, CalibPatternOptions& p);

// The plate the options describe, validated (an unknown pattern or dictionary is an error).
Result<vision::calib::PatternSpec> patternSpec(const CalibPatternOptions& o);

// One progress line per image on stderr: "[#####-----]  5/10 name: status".
void progress(std::size_t i, std::size_t n, const std::string& name, const std::string& status);

// "vgr calibrate: <msg>" on stderr; returns 2 (bad input).
int bad(const std::string& msg);

// Checked before any image is read: `path` (an --out file) can be written: its folder
// exists and is writable, and it is no folder itself. Creates nothing.
Result<void> checkOutputPath(const std::string& path, const std::string& option = "--out");

// "vgr calibrate: implausible <what>: <why>. <hint>" on stderr, no file written; returns 1
// (the data were read, the result is not one vgrd would load: vision/calib/mapping.hpp
// CellCalibrationLimits).
int implausible(const std::string& what, const std::string& why, const std::string& hint);

}  // namespace vgr::tools
