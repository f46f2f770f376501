// The files of a 3D data set (docs/3d.md "Data-set format"; the format is fixed, other tools
// produce and read it):
//   DIR/camera.yaml   width, height, fx, fy, cx, cy, depth_scale_mm
//   DIR/truth.csv     image,x_mm,y_mm,z_mm,qw,qx,qy,qz[,...]: pose of the model frame in the
//                     camera frame, one row per part; an image without a part: one row with
//                     empty fields
//   DIR/views/views.csv  view,x_mm,...,qz,noisy_x_mm,...,noisy_qz[,...]: the camera's pose in
//                     the model frame, true and as the robot reported it
//   DIR/images/*.png  16-bit z images (listDepthImages names them; their pixels are read
//                     elsewhere: vision/depth_image.hpp, the replay and emulator cameras)
// PLY files are read in vision/ply_file.hpp.
// Parse -> validate; every error names the file and line (and the key for YAML):
// "DIR/camera.yaml:3: key 'fx': expected a number in [...]". Start-up style I/O, any thread.
#pragma once

#include <string>
#include <vector>

#include "core/depth.hpp"
#include "core/pose.hpp"
#include "core/result.hpp"

namespace vgr::config {

struct DepthCameraFile {
  int width = 0, height = 0;     // px, [1, 65535]
  double fx = 0, fy = 0;         // px, > 0
  double cx = 0, cy = 0;         // px, inside the image: [0, width - 1] x [0, height - 1]
  double depthScaleMm = 0;       // mm per 16-bit step, (0, 100]; 0 in an image = no data

  DepthIntrinsics intrinsics() const { return {fx, fy, cx, cy, width, height}; }
  void setIntrinsics(const DepthIntrinsics& k) { fx = k.fx, fy = k.fy, cx = k.cx, cy = k.cy; }
};

std::string depthCameraYaml(const DepthCameraFile& c);
Result<void> writeDepthCameraFile(const std::string& path, const DepthCameraFile& c);
// Errors: Status::BadArgument "PATH: cannot open" (missing), "PATH:LINE: key 'k': what"
// (a missing key, a value out of range, an unknown key, a principal point off the image).
Result<DepthCameraFile> loadDepthCameraFile(const std::string& path);

// One row of truth.csv.
struct DepthTruthRow {
  std::string image;   // relative to the data set's folder, e.g. images/0000.png
  bool hasPart = false;  // false: the image's one row with empty fields
  Pose pose;           // T_cam_model (mm, unit quaternion, qw >= 0)
  int line = 0;        // line in truth.csv
};
// Errors: Status::BadArgument "PATH:LINE: what" for a header without the fixed columns, a
// row with another number of fields, a number that does not parse, a quaternion that is not
// unit length (|q| off 1 by more than 1e-3), an image with an empty row and a part row.
Result<std::vector<DepthTruthRow>> loadDepthTruth(const std::string& path);

struct DepthViewRow {
  std::string view;  // file name in the views folder
  Pose truth;        // T_model_cam, true
  Pose reported;     // T_model_cam as the robot reported it
  int line = 0;
};
// Errors as loadDepthTruth; additionally "PATH:LINE: view 'x': no such file" when the view's
// image is not in the folder of views.csv.
Result<std::vector<DepthViewRow>> loadDepthViews(const std::string& path);

// DIR/images/*.png in name order, relative to DIR ("images/0000.png"). Errors
// (Status::BadArgument): "DIR/images: no such folder ...", "DIR/images: no .png depth images".
Result<std::vector<std::string>> listDepthImages(const std::string& dir);

// Writes truth.csv from rows (hasPart false: the image's row of empty fields).
Result<void> writeDepthTruth(const std::string& path, const std::vector<DepthTruthRow>& rows);

// Writes rows as the fixed format (mm to 4 decimals, quaternions to 8).
std::string depthTruthCsvHeader();
std::string depthTruthCsvRow(const std::string& image, const Pose* pose);  // nullptr: empty fields
std::string depthViewsCsvHeader();
std::string depthViewsCsvRow(const std::string& view, const Pose& truth, const Pose& reported);

}  // namespace vgr::config
