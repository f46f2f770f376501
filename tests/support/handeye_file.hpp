// A hand-eye file for tests that know the camera's true mounting: handeye.yaml in the
// calibration format (vision/calib/handeye.hpp) with one method, "truth", X as given and
// residuals well inside the cell's limits (vgrd maps with it like with a calibrated one).
// Header only; test thread.
#pragma once

#include <string>

#include "core/pose.hpp"
#include "vision/calib/handeye.hpp"

namespace vgr::test {

// x: T_flange_cam (eye-in-hand) or T_base_cam (eye-to-hand). False when it cannot be written.
inline bool writeTruthHandEye(const std::string& path, vision::calib::HandEyeConfig config, const Pose& x) {
  vision::calib::HandEyeResult he;
  he.config = config;
  vision::calib::HandEyeMethodResult m;
  m.method = "truth";
  m.valid = true;
  m.x = x;
  m.transResidMm = 0.05;
  m.rotResidDeg = 0.01;
  m.reprojRmsPx = 0.1;
  he.methods.push_back(m);
  he.best = 0;
  return static_cast<bool>(vision::calib::writeHandEye(path, he));
}

}  // namespace vgr::test
