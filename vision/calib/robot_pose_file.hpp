// The robot pose file (docs/calibration.md, "poses.txt"): what `vgr calibrate handeye`
// reads next to the images and `vgr calibrate synth` writes. One line per image,
//   <image> x y z a b c [d]
// in the controller's own convention, after a "format abb|fanuc|ur" and a "units mm|m" line:
//   abb:   x y z mm, qw qx qy qz
//   fanuc: x y z mm, W P R deg with R = Rz(R) Ry(P) Rx(W)
//   ur:    x y z m,  rotation vector rx ry rz rad
// '#' starts a comment. Poses are T_base_gripper (mm inside, core/pose.hpp). Parse and write
// live together here so the two stay one format.
#pragma once

#include <string>
#include <vector>

#include "core/pose.hpp"
#include "core/result.hpp"

namespace vgr::vision::calib {

struct PoseEntry {
  std::string image;
  Pose baseFromGripper;  // mm
  int line = 0;          // 1-based line in the file (0 for poses not read from one)
};

// Errors (Status::BadArgument) read "SOURCE:LINE: what".
Result<std::vector<PoseEntry>> parsePoseFile(const std::string& text, const std::string& sourceName);
Result<std::vector<PoseEntry>> loadPoseFile(const std::string& path);

// The file's text for `format` (abb, fanuc or ur; ur in metres, the others in mm), with a
// comment line first. Fixed notation: 4 decimals for mm and degrees (fanuc: 6), 7 for metres,
// 9 for quaternions and rotation vectors.
Result<std::string> poseFileText(const std::string& format, const std::vector<PoseEntry>& poses);
Result<void> writePoseFile(const std::string& path, const std::string& format, const std::vector<PoseEntry>& poses);

}  // namespace vgr::vision::calib
