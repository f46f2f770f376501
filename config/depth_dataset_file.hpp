// The 3D data-set format (issue 13, fixed; other tools produce and read it), as far as the
// cameras and the calibration read it:
//   DIR/camera.yaml  width, height, fx, fy, cx, cy, depth_scale_mm (value v -> v * depth_scale_mm
//                    mm of z; 0 = no data); other keys are left to their writers
//   DIR/images/*.png 16-bit single-channel z-depth images
//   DIR/truth.csv    image,x_mm,y_mm,z_mm,qw,qx,qy,qz[,...]: the pose of the model frame in the
//                    camera frame per part (x right, y down, z forward; mm, unit quaternion,
//                    qw >= 0); an image without a part has one row with empty fields
// Readers validate what they read and name file, line and key (or column) of the first
// problem (Status::BadArgument). Writers produce exactly this layout (tests, synthetic sets).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/depth.hpp"
#include "core/pose.hpp"
#include "core/result.hpp"

namespace vgr::config {

struct DepthCameraFile {
  int width = 0, height = 0;  // px, [1, 65535]
  DepthIntrinsics intrinsics;  // fx, fy > 0; cx in [0, width), cy in [0, height)
  double depthScaleMm = 0;     // mm per depth unit, (0, 100]
};
Result<DepthCameraFile> loadDepthCameraFile(const std::string& path);
Result<void> writeDepthCameraFile(const std::string& path, const DepthCameraFile& camera);

// One row of truth.csv.
struct DepthTruthRow {
  std::string image;            // path relative to DIR, e.g. "images/0000.png"
  std::optional<Pose> modelInCamera;  // empty: an image without a part
  int line = 0;                 // 1-based line in the file
};
// Rows in file order. A header without the eight columns in that order, a row with another
// number of fields than the header, a number that does not parse, a quaternion whose norm is
// off 1 by more than 1e-3 or with qw < 0: errors naming the line and column.
Result<std::vector<DepthTruthRow>> loadDepthTruthCsv(const std::string& path);
Result<void> writeDepthTruthCsv(const std::string& path, const std::vector<DepthTruthRow>& rows);

// DIR/images/*.png in name order (paths relative to DIR, "images/0000.png"); an error when the
// folder is missing or holds none.
Result<std::vector<std::string>> listDepthImages(const std::string& dir);

}  // namespace vgr::config
