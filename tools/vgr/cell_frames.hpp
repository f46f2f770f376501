// What `vgr calibrate verify` and `vgr repeatability` share: frames of a cell (grabbed from
// its camera, as vgrd grabs them, or read from files) and the cycle's locate + map steps on
// one frame, done exactly as vgrd's cycle runner does them (daemon::makeJobLocator,
// daemon::makeCellMapping, vision::partPoses with the job's height, angle offset and
// reference). One thread.
#pragma once

#include <memory>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "core/result.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/locate/locator.hpp"
#include "vision/part_poses.hpp"

namespace vgr::tools {

// `count` frames from the cell's camera (its camera section, software trigger, the cycle
// deadline per frame), as 8-bit gray (vision::toGray8). The camera must be free: while
// vgrd runs it holds it (error naming the camera).
Result<std::vector<cv::Mat>> grabCellFrames(const config::CellConfig& cell, int count);

// Image files (paths or glob patterns, cv::glob), as 8-bit gray, in name order. Error:
// nothing matches, or one cannot be read.
Result<std::vector<cv::Mat>> readFrames(const std::vector<std::string>& pathsOrGlobs, std::vector<std::string>* names = nullptr);

struct CellJob {
  int id = 0;
  std::unique_ptr<vision::Locator> locator;
  vision::PartPoseRules rules;
};
// Job `jobId` of the cell (0: its first job).
Result<CellJob> makeCellJob(const config::CellConfig& cell, int jobId);

// The parts of one frame in the robot base frame, best first (empty: none found). Error: a
// frame of another size than the calibration's (NOT_CALIBRATED) or the locator's error.
Result<std::vector<PartResult>> locateParts(CellJob& job, const vision::calib::PixelMapping& mapping, const cv::Mat& gray);

}  // namespace vgr::tools
