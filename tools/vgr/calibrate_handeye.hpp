// `vgr calibrate handeye`: hand-eye from a folder of plate images + the robot poses in
// poses.txt (docs/calibration.md). With --cloud: from depth images of a sphere target
// (camera.yaml of the 3D data-set format, target.yaml, poses.txt; paper 003's point-cloud
// registration, vision/calib/handeye_cloud.hpp).
// Returns the process exit code: 0 ok, 2 bad input (message on stderr naming file / view / key).
#pragma once

#include <cstddef>
#include <optional>
#include <string>

#include <nlohmann/json_fwd.hpp>

#include "tools/vgr/calibrate_common.hpp"
#include "tools/vgr/subcommand.hpp"
#include "vision/calib/handeye.hpp"

namespace vgr::tools {

struct CalibHandEyeOptions {
  std::string folder;          // holds poses.txt and the images it names
  std::string intrinsics;      // intrinsics.yaml (2D camera; not with --cloud)
  bool cloud = false;          // a depth camera: depth images of a sphere target
  std::string target;          // --cloud: target.yaml (default FOLDER/target.yaml)
  std::string camera;          // --cloud: camera.yaml of the depth images (default FOLDER/camera.yaml)
  std::string configuration = "auto";  // eye-in-hand | eye-to-hand | auto
  CalibPatternOptions pattern;
  std::string out = "handeye.yaml";
  std::string truth;           // optional: a truth.yaml from `vgr calibrate synth` -> errors per method
  bool json = false;
};

int runCalibrateHandEye(const CalibHandEyeOptions& o);
int runCalibrateHandEyeCloud(const CalibHandEyeOptions& o);  // calibrate_handeye_cloud.cpp

// What both modes print and report (calibrate_handeye.cpp): the truth file of --truth
// (nullopt without one), and the per-method table on stdout with each method's residuals,
// its fit (`fitName`: "reproj_px" for the plate, "point_mm" for the sphere target) and,
// with a truth, its error from it; returns the same rows as JSON for --json.
Result<std::optional<vision::calib::HandEyeFile>> readHandEyeTruth(const std::string& path);
nlohmann::json printHandEyeMethods(const vision::calib::HandEyeResult& r,
                                   const std::optional<vision::calib::HandEyeFile>& truth, const char* fitName);
// Writes the chosen result to o.out, says so, and with --json prints the summary line
// (the best method, its residuals and fit `fitName`, views used, the method rows). Returns
// the exit code: 0, or 2 when the file cannot be written.
int writeHandEyeAndReport(const CalibHandEyeOptions& o, const vision::calib::HandEyeResult& r, const char* fitName,
                          std::size_t viewsUsed, const nlohmann::json& methods);

class CalibrateHandEyeCommand final : public OptionsSubcommand<CalibHandEyeOptions, runCalibrateHandEye> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
