// check.yaml (OpenCV FileStorage): where the calibration check targets are, for
// `vgr calibrate verify` and vgrd's drift monitor (docs/calibration.md, "Checking a
// calibration"). Written by `vgr calibrate verify --store` right after a calibration known
// to be good (the targets measured through it), or by hand with robot-touched positions.
// Two targets, each optional (at least one):
//   fiducial: a round mark fixed in the cell, always in view: its search window (px),
//             polarity, height above the work plane, its stored position (base frame, mm)
//             and the area it was seen with (px², 0 = any);
//   part:     a check part of a cell job lying at a fixed place: the job id and its stored
//             pose (x, y, z mm, rz deg, base frame).
// tolerance_mm / tolerance_deg: what verify passes with. Errors name the file and the key.
#pragma once

#include <string>

#include <opencv2/core.hpp>

#include "core/pose.hpp"
#include "core/result.hpp"

namespace vgr::vision::calib {

struct CheckFile {
  double toleranceMm = 0.2;   // mm, > 0
  double toleranceDeg = 0.1;  // deg, > 0
  struct Fiducial {
    bool present = false;
    cv::Rect window;          // px
    bool bright = true;
    double heightMm = 0;      // mm above the work plane
    Vec3 positionMm;          // stored, base frame
    double areaPx = 0;        // px² when stored; 0 = not checked
  } fiducial;
  struct Part {
    bool present = false;
    int job = 0;              // a job id of the cell
    double xMm = 0, yMm = 0, zMm = 0, rzDeg = 0;  // stored, base frame
  } part;
  std::string stored;         // free text: when / how it was stored
};

// Errors: Status::NotCalibrated, "PATH: ..." naming the key.
Result<CheckFile> readCheckFile(const std::string& path);
Result<void> writeCheckFile(const std::string& path, const CheckFile& check);

}  // namespace vgr::vision::calib
