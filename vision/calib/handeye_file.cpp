#include "vision/calib/handeye.hpp"

#include <exception>
#include <filesystem>

#include <Eigen/Geometry>
#include <fmt/core.h>
#include <opencv2/core/persistence.hpp>

#include "vision/calib/calib_file_guard.hpp"
#include "vision/calib/se3.hpp"

// handeye.yaml and the synthetic sets' truth.yaml (same layout): written and read here only.
namespace vgr::vision::calib {

using se3::Iso;

namespace {

// A pose as the 4 x 4 homogeneous matrix the files store.
cv::Mat homogeneous(const Pose& p) {
  const Eigen::Matrix4d m = se3::toIso(p).matrix();
  cv::Mat out(4, 4, CV_64F);
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j) out.at<double>(i, j) = m(i, j);
  return out;
}

}  // namespace

Result<void> writeHandEyeTruth(const std::string& path, HandEyeConfig config, const Pose& x, const Pose& y) {
  try {
    cv::FileStorage f(path, cv::FileStorage::WRITE);
    if (!f.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot open for writing", path));
    f << "calibration_kind" << "handeye_truth" << "configuration" << handEyeConfigName(config);
    f << "x" << homogeneous(x) << "y" << homogeneous(y) << "method" << "truth";
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  return {};
}

Result<void> writeHandEye(const std::string& path, const HandEyeResult& r) {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot open for writing", path));
    const auto& b = r.bestResult();
    const auto mat = homogeneous;
    fs << "calibration_kind" << "handeye";
    fs << "configuration" << handEyeConfigName(r.config);
    fs << "x_meaning" << (r.config == HandEyeConfig::EyeInHand ? "T_gripper_cam" : "T_base_cam");
    fs << "y_meaning" << (r.config == HandEyeConfig::EyeInHand ? "T_base_target" : "T_gripper_target");
    fs << "x" << mat(b.x) << "y" << mat(b.y);
    fs << "method" << b.method << "reason" << r.reason;
    fs << "trans_resid_mm" << b.transResidMm << "rot_resid_deg" << b.rotResidDeg << "reproj_rms_px" << b.reprojRmsPx;
    fs << "point_rms_mm" << b.pointRmsMm;
    fs << "methods" << "[";
    for (const auto& m : r.methods)
      fs << "{" << "method" << m.method << "valid" << (m.valid ? 1 : 0) << "trans_resid_mm" << m.transResidMm
         << "rot_resid_deg" << m.rotResidDeg << "reproj_rms_px" << m.reprojRmsPx << "point_rms_mm" << m.pointRmsMm
         << "note" << m.note << "}";
    fs << "]";
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  return {};
}

Result<HandEyeFile> readHandEye(const std::string& path) {
  HandEyeFile f;
  if (!std::filesystem::exists(path)) return fail(Status::NotCalibrated, fmt::format("{}: no such hand-eye file", path));
  try {
    requireYamlText(path);
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return fail(Status::NotCalibrated, fmt::format("{}: cannot open hand-eye file", path));
    const std::string cfg = static_cast<std::string>(fs["configuration"]);
    if (cfg == "eye-in-hand") f.config = HandEyeConfig::EyeInHand;
    else if (cfg == "eye-to-hand") f.config = HandEyeConfig::EyeToHand;
    else return fail(Status::NotCalibrated, fmt::format("{}: key 'configuration': expected eye-in-hand or eye-to-hand, got '{}'", path, cfg));
    for (const char* key : {"x", "y"}) {
      cv::Mat m;
      if (!readSmallMatrix(fs[key], 4, 4, m))
        return fail(Status::NotCalibrated, fmt::format("{}: key '{}': missing or not 4x4", path, key));
      Iso t = Iso::Identity();
      for (int i = 0; i < 3; ++i) {
        for (int j = 0; j < 3; ++j) t.linear()(i, j) = m.at<double>(i, j);
        t.translation()(i) = m.at<double>(i, 3);
      }
      if (!se3::isValidRigid(t)) return fail(Status::NotCalibrated, fmt::format("{}: key '{}': not a rigid transform", path, key));
      (key[0] == 'x' ? f.x : f.y) = se3::toPose(t);
    }
    f.method = static_cast<std::string>(fs["method"]);
    f.transResidMm = static_cast<double>(fs["trans_resid_mm"]);
    f.rotResidDeg = static_cast<double>(fs["rot_resid_deg"]);
    f.reprojRmsPx = static_cast<double>(fs["reproj_rms_px"]);
    f.pointRmsMm = fs["point_rms_mm"].empty() ? 0.0 : static_cast<double>(fs["point_rms_mm"]);
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::NotCalibrated, fmt::format("{}: {}", path, e.what()));
  }
  return f;
}

}  // namespace vgr::vision::calib
