#include "vision/calib/intrinsics.hpp"

#include <cmath>
#include <exception>
#include <filesystem>

#include <fmt/core.h>
#include <opencv2/core/persistence.hpp>

#include "vision/calib/calib_file_guard.hpp"

// intrinsics.yaml (and a synthetic set's camera_truth.yaml, same layout): written and read
// here only.
namespace vgr::vision::calib {

Result<void> writeIntrinsics(const std::string& path, const CameraIntrinsics& cam) {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot open for writing", path));
    fs << "calibration_kind" << "intrinsics";
    fs << "image_width" << cam.imageSize.width << "image_height" << cam.imageSize.height;
    fs << "camera_matrix" << cv::Mat(cam.cameraMatrix);
    fs << "distortion_coefficients" << cv::Mat(cam.dist);
    fs << "rms_px" << cam.rmsPx;
    fs << "tangential_distortion" << (cam.tangential ? 1 : 0);
    fs << "std_dev_intrinsics" << cv::Mat(cam.stdDev);  // fx fy cx cy k1 k2 p1 p2 k3
    fs << "views" << "[";
    for (const auto& v : cam.views)
      fs << "{" << "name" << v.name << "rms_px" << v.rmsPx << "tilt_deg" << v.tiltDeg << "used" << (v.used ? 1 : 0) << "}";
    fs << "]";
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  return {};
}

Result<CameraIntrinsics> readIntrinsics(const std::string& path) {
  CameraIntrinsics cam;
  if (!std::filesystem::exists(path)) return fail(Status::NotCalibrated, fmt::format("{}: no such intrinsics file", path));
  try {
    requireYamlText(path);
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return fail(Status::NotCalibrated, fmt::format("{}: cannot open intrinsics file", path));
    cv::Mat k, d;
    if (!readSmallMatrix(fs["camera_matrix"], 3, 3, k))
      return fail(Status::NotCalibrated, fmt::format("{}: key 'camera_matrix': missing or not 3x3", path));
    if (!readSmallMatrix(fs["distortion_coefficients"], 5, 1, d) && !readSmallMatrix(fs["distortion_coefficients"], 1, 5, d))
      return fail(Status::NotCalibrated, fmt::format("{}: key 'distortion_coefficients': expected 5 values", path));
    cam.cameraMatrix = cv::Matx33d(k);
    for (int i = 0; i < 5; ++i) cam.dist[i] = d.at<double>(i);
    cam.imageSize = cv::Size(static_cast<int>(fs["image_width"]), static_cast<int>(fs["image_height"]));
    cam.rmsPx = static_cast<double>(fs["rms_px"]);
    if (!fs["tangential_distortion"].empty()) cam.tangential = static_cast<int>(fs["tangential_distortion"]) != 0;
    if (!fs["std_dev_intrinsics"].empty()) {
      cv::Mat sdm;
      if (readSmallMatrix(fs["std_dev_intrinsics"], 9, 1, sdm)) {
        for (int i = 0; i < 9; ++i) cam.stdDev[i] = sdm.at<double>(i);
      }
    }
    const cv::FileNode views = fs["views"];
    for (const auto& n : views)
      cam.views.push_back({static_cast<std::string>(n["name"]), static_cast<double>(n["rms_px"]),
                           static_cast<double>(n["tilt_deg"]), static_cast<int>(n["used"]) != 0});
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::NotCalibrated, fmt::format("{}: {}", path, e.what()));
  }
  // A number too large for a double (1e+2607) reads as infinite: refused like a missing one
  // (found by fuzz_calib_files: an infinite cx loaded).
  for (int i = 0; i < 9; ++i)
    if (!std::isfinite(cam.cameraMatrix.val[i]))
      return fail(Status::NotCalibrated, fmt::format("{}: key 'camera_matrix': value {} is not a finite number", path, i + 1));
  for (int i = 0; i < 5; ++i)
    if (!std::isfinite(cam.dist[i]))
      return fail(Status::NotCalibrated, fmt::format("{}: key 'distortion_coefficients': value {} is not a finite number", path, i + 1));
  if (!(cam.fx() > 0 && cam.fy() > 0) || cam.imageSize.width <= 0 || cam.imageSize.height <= 0)
    return fail(Status::NotCalibrated, fmt::format("{}: focal lengths and image size must be positive", path));
  return cam;
}

}  // namespace vgr::vision::calib
