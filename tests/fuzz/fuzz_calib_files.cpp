// libFuzzer target: the calibration files vgrd and `vgr` load (docs/calibration.md):
// intrinsics.yaml, handeye.yaml, plane.yaml, multiheight.yaml (OpenCV FileStorage YAML) and
// the robot pose file (text, every controller's format). Byte 0 picks the reader; the rest
// is the file (written to a temporary file for the path-based readers). Checks: no crash,
// leak or UB; failures carry the documented codes (NOT_CALIBRATED for calibration files,
// BAD_ARGUMENT "SOURCE:LINE: ..." for pose files); an accepted file gives finite numbers
// and a unit rotation (a calibration that loads is one vgrd can map with).
#include <unistd.h>

#include <cmath>
#include <cstddef>
#include <cstdint>
#include <cstdlib>
#include <filesystem>
#include <fstream>
#include <string>

#include "vision/calib/handeye.hpp"
#include "vision/calib/intrinsics.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/multi_height_file.hpp"
#include "vision/calib/robot_pose_file.hpp"

namespace {

void check(bool ok) {
  if (!ok) std::abort();
}

bool finitePose(const vgr::Pose& p) {
  const double n = std::sqrt(p.qw * p.qw + p.qx * p.qx + p.qy * p.qy + p.qz * p.qz);
  return std::isfinite(p.x) && std::isfinite(p.y) && std::isfinite(p.z) && std::abs(n - 1.0) < 1e-6;
}

bool calibrationError(const vgr::Error& e) {
  return e.code == vgr::Status::NotCalibrated || e.code == vgr::Status::BadArgument;
}

}  // namespace

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  namespace calib = vgr::vision::calib;
  if (size == 0) return 0;
  const int kind = data[0] % 5;
  const std::string text(reinterpret_cast<const char*>(data + 1), size - 1);
  if (kind == 4) {
    const auto poses = calib::parsePoseFile(text, "poses.txt");
    if (!poses) {
      check(poses.error().code == vgr::Status::BadArgument);
      check(poses.error().message.rfind("poses.txt", 0) == 0);
      return 0;
    }
    for (const auto& p : *poses) check(finitePose(p.baseFromGripper));
    return 0;
  }
  // FileStorage picks the format by the extension: .yaml, as the real files.
  static const std::string path =
      (std::filesystem::temp_directory_path() / ("vgr-fuzz-calib-" + std::to_string(::getpid()) + ".yaml")).string();
  std::ofstream(path, std::ios::binary | std::ios::trunc).write(text.data(), static_cast<std::streamsize>(text.size()));
  switch (kind) {
    case 0: {
      const auto cam = calib::readIntrinsics(path);
      if (!cam) return check(calibrationError(cam.error())), 0;
      check(cam->fx() > 0 && cam->fy() > 0 && std::isfinite(cam->cx()) && std::isfinite(cam->cy()));
      check(cam->imageSize.width > 0 && cam->imageSize.height > 0);
      for (int i = 0; i < 5; ++i) check(std::isfinite(cam->dist[i]));
      return 0;
    }
    case 1: {
      const auto he = calib::readHandEye(path);
      if (!he) return check(calibrationError(he.error())), 0;
      check(finitePose(he->x) && finitePose(he->y));
      return 0;
    }
    case 2: {
      const auto plane = calib::readWorkPlane(path);
      if (!plane) return check(calibrationError(plane.error())), 0;
      const auto& n = plane->normal;
      check(std::isfinite(plane->point.x + plane->point.y + plane->point.z));
      check(std::abs(std::sqrt(n.x * n.x + n.y * n.y + n.z * n.z) - 1.0) < 1e-6);
      return 0;
    }
    default: {
      const auto mh = calib::readMultiHeight(path);
      if (!mh) return check(calibrationError(mh.error())), 0;
      check(mh->fit.rmsPx <= 1.0);
      return 0;
    }
  }
}
