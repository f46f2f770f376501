#include "vision/calib/mapping.hpp"

#include <exception>
#include <cmath>
#include <filesystem>

#include <Eigen/SVD>
#include <fmt/core.h>
#include <opencv2/calib3d.hpp>

#include "vision/calib/calib_file_guard.hpp"
#include "vision/calib/se3.hpp"

namespace vgr::vision::calib {
namespace {

Eigen::Vector3d ev(const Vec3& v) { return {v.x, v.y, v.z}; }
Vec3 vv(const Eigen::Vector3d& v) { return {v.x(), v.y(), v.z()}; }

// The plane's normal turned toward the camera at camPos (heights count toward the camera).
Eigen::Vector3d normalTowardCamera(const WorkPlane& plane, const Eigen::Vector3d& camPos) {
  Eigen::Vector3d n = ev(plane.normal).normalized();
  if (n.dot(camPos - ev(plane.point)) < 0) n = -n;
  return n;
}

// Distortion removed (iteratively, to 1e-12), then the normalised ray (paper 002, eqs. 5-7)
// in the base frame, intersected with the plane raised by heightMm along n (eqs. 8-11).
std::optional<Vec3> rayOnPlane(const CameraIntrinsics& camera, const Pose& baseFromCamera, const Vec3& planePoint,
                               const Eigen::Vector3d& n, PixelPoint p, double heightMm) {
  std::vector<cv::Point2d> src{{p.u, p.v}}, dst;
  cv::undistortPoints(src, dst, camera.cameraMatrix, camera.dist, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-12));
  const se3::Iso t = se3::toIso(baseFromCamera);
  const Eigen::Vector3d dir = t.linear() * Eigen::Vector3d(dst[0].x, dst[0].y, 1.0);
  const Eigen::Vector3d o = t.translation();
  const Eigen::Vector3d q = ev(planePoint) + heightMm * n;
  const double den = n.dot(dir);
  if (std::abs(den) < 1e-12) return std::nullopt;
  const double s = n.dot(q - o) / den;
  if (s <= 0) return std::nullopt;
  return vv(o + s * dir);
}

}  // namespace

WorkPlane planeFromPlate(const Pose& baseFromCamera, const Pose& camFromPlate, double plateThicknessMm) {
  const se3::Iso t = se3::toIso(baseFromCamera) * se3::toIso(camFromPlate);
  Eigen::Vector3d n = t.linear().col(2);
  const Eigen::Vector3d camPos = se3::toIso(baseFromCamera).translation();
  if (n.dot(camPos - t.translation()) < 0) n = -n;  // toward the camera (up from the plate)
  WorkPlane p;
  p.point = vv(t.translation() - plateThicknessMm * n);
  p.normal = vv(n);
  return p;
}

Result<WorkPlane> planeFromPoints(const std::vector<Vec3>& pts) {
  if (pts.size() < 3)
    return fail(Status::BadArgument, fmt::format("work plane: {} touched points, at least 3 needed", pts.size()));
  Eigen::Vector3d c = Eigen::Vector3d::Zero();
  for (const auto& p : pts) c += ev(p);
  c /= static_cast<double>(pts.size());
  Eigen::MatrixXd m(pts.size(), 3);
  for (std::size_t i = 0; i < pts.size(); ++i) m.row(static_cast<Eigen::Index>(i)) = (ev(pts[i]) - c).transpose();
  Eigen::JacobiSVD<Eigen::MatrixXd> svd(m, Eigen::ComputeThinV);
  const Eigen::Vector3d s = svd.singularValues();
  if (s(1) < 1e-6 * std::max(1.0, s(0)))
    return fail(Status::BadArgument, "work plane: the touched points are collinear (or all the same point)");
  Eigen::Vector3d n = svd.matrixV().col(2);
  if (n.z() < 0) n = -n;
  WorkPlane p;
  p.point = vv(c);
  p.normal = vv(n.normalized());
  p.fitRmsMm = s(2) / std::sqrt(static_cast<double>(pts.size()));
  return p;
}

CameraPlaneMapping::CameraPlaneMapping(const CameraIntrinsics& camera, const Pose& baseFromCamera,
                                       const WorkPlane& plane)
    : camera_(camera), baseFromCamera_(baseFromCamera), plane_(plane) {
  plane_.normal = vv(normalTowardCamera(plane_, se3::toIso(baseFromCamera_).translation()));
}

EyeInHandPlaneMapping::EyeInHandPlaneMapping(const CameraIntrinsics& camera, const Pose& flangeFromCamera,
                                             const WorkPlane& plane)
    : camera_(camera), flangeFromCamera_(flangeFromCamera), plane_(plane) {
  plane_.normal = vv(ev(plane_.normal).normalized());
}

Pose EyeInHandPlaneMapping::baseFromCamera(const Pose& baseFromFlange) const {
  return compose(baseFromFlange, flangeFromCamera_);
}

std::optional<Vec3> EyeInHandPlaneMapping::pixelToRobot(PixelPoint p, double heightMm, const Pose& baseFromFlange) const {
  const Pose cam = baseFromCamera(baseFromFlange);
  const Eigen::Vector3d n = normalTowardCamera(plane_, se3::toIso(cam).translation());
  return rayOnPlane(camera_, cam, plane_.point, n, p, heightMm);
}

std::optional<Vec3> CameraPlaneMapping::pixelToRobot(PixelPoint p, double heightMm) const {
  return rayOnPlane(camera_, baseFromCamera_, plane_.point, ev(plane_.normal), p, heightMm);
}

std::optional<PixelPoint> CameraPlaneMapping::robotToPixel(const Vec3& pb) const {
  const Eigen::Vector3d pc = se3::toIso(baseFromCamera_).inverse() * ev(pb);
  if (pc.z() <= 1e-9) return std::nullopt;
  std::vector<cv::Point3d> obj{{pc.x(), pc.y(), pc.z()}};
  std::vector<cv::Point2d> img;
  cv::projectPoints(obj, cv::Vec3d(0, 0, 0), cv::Vec3d(0, 0, 0), camera_.cameraMatrix, camera_.dist, img);
  return PixelPoint{img[0].x, img[0].y};
}

}  // namespace vgr::vision::calib

#include "vision/calib/handeye.hpp"

namespace vgr::vision::calib {

Result<void> writeWorkPlane(const std::string& path, const WorkPlane& plane, const std::string& source) {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot open for writing", path));
    fs << "calibration_kind" << "plane" << "source" << source;
    fs << "point_mm" << cv::Vec3d(plane.point.x, plane.point.y, plane.point.z);
    fs << "normal" << cv::Vec3d(plane.normal.x, plane.normal.y, plane.normal.z);
    fs << "fit_rms_mm" << plane.fitRmsMm;
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  return {};
}

Result<WorkPlane> readWorkPlane(const std::string& path) {
  WorkPlane p;
  if (!std::filesystem::exists(path)) return fail(Status::NotCalibrated, fmt::format("{}: no such plane file", path));
  try {
    requireYamlText(path);
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return fail(Status::NotCalibrated, fmt::format("{}: cannot open plane file", path));
    cv::Vec3d pt, n;
    if (fs["point_mm"].empty() || fs["normal"].empty())
      return fail(Status::NotCalibrated, fmt::format("{}: keys 'point_mm' and 'normal' are required", path));
    fs["point_mm"] >> pt;
    fs["normal"] >> n;
    const double len = cv::norm(n);
    if (!(len > 0.5 && len < 1.5) || !std::isfinite(pt[0] + pt[1] + pt[2]))
      return fail(Status::NotCalibrated, fmt::format("{}: key 'normal': not a unit vector", path));
    p.point = {pt[0], pt[1], pt[2]};
    p.normal = {n[0] / len, n[1] / len, n[2] / len};
    p.fitRmsMm = static_cast<double>(fs["fit_rms_mm"]);
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::NotCalibrated, fmt::format("{}: {}", path, e.what()));
  }
  return p;
}

namespace {

struct CalibrationFiles {
  CameraIntrinsics camera;
  HandEyeFile handEye;
  WorkPlane plane;
};

// The three files, read and checked against the limits (every configuration).
Result<CalibrationFiles> readCalibrationFiles(const std::string& intrinsicsPath, const std::string& handEyePath,
                                              const std::string& planePath, const CellCalibrationLimits& limits) {
  auto cam = readIntrinsics(intrinsicsPath);
  if (!cam) return std::unexpected(cam.error());
  if (cam->rmsPx > limits.maxReprojPx)
    return fail(Status::NotCalibrated, fmt::format("{}: accepted with rms_px {:.3f}, above the {:.2f} px limit: "
                                                   "recalibrate",
                                                   intrinsicsPath, cam->rmsPx, limits.maxReprojPx));
  auto he = readHandEye(handEyePath);
  if (!he) return std::unexpected(he.error());
  if (he->reprojRmsPx > limits.maxReprojPx || he->transResidMm > limits.maxHandEyeMm ||
      he->rotResidDeg > limits.maxHandEyeDeg || he->pointRmsMm > limits.maxPointRmsMm)
    return fail(Status::NotCalibrated,
                fmt::format("{}: residuals {:.3f} px / {:.3f} mm / {:.4f} deg / points {:.3f} mm exceed the limits {:.2f} px / "
                            "{:.2f} mm / {:.2f} deg / {:.2f} mm: recalibrate",
                            handEyePath, he->reprojRmsPx, he->transResidMm, he->rotResidDeg, he->pointRmsMm,
                            limits.maxReprojPx, limits.maxHandEyeMm, limits.maxHandEyeDeg, limits.maxPointRmsMm));
  auto plane = readWorkPlane(planePath);
  if (!plane) return std::unexpected(plane.error());
  return CalibrationFiles{*cam, *he, *plane};
}

}  // namespace

Result<CameraPlaneMapping> loadCellCalibration(const std::string& intrinsicsPath, const std::string& handEyePath,
                                               const std::string& planePath, const CellCalibrationLimits& limits) {
  auto files = readCalibrationFiles(intrinsicsPath, handEyePath, planePath, limits);
  if (!files) return std::unexpected(files.error());
  if (files->handEye.config != HandEyeConfig::EyeToHand)
    return fail(Status::NotCalibrated, fmt::format("{}: configuration eye-in-hand: the camera rides on the flange and "
                                                   "maps with each snapshot's flange pose "
                                                   "(loadEyeInHandCalibration), not as a fixed camera",
                                                   handEyePath));
  // The camera must see the plane from its front: the optical axis points toward it.
  const se3::Iso x = se3::toIso(files->handEye.x);
  const Eigen::Vector3d axis = x.linear().col(2);
  const Eigen::Vector3d toPlane = ev(files->plane.point) - x.translation();
  if (axis.dot(toPlane) <= 0)
    return fail(Status::NotCalibrated, fmt::format("{} and {}: the plane lies behind the camera (files from different "
                                                   "cells?)",
                                                   handEyePath, planePath));
  return CameraPlaneMapping(files->camera, files->handEye.x, files->plane);
}

Result<EyeInHandPlaneMapping> loadEyeInHandCalibration(const std::string& intrinsicsPath, const std::string& handEyePath,
                                                       const std::string& planePath, const CellCalibrationLimits& limits) {
  auto files = readCalibrationFiles(intrinsicsPath, handEyePath, planePath, limits);
  if (!files) return std::unexpected(files.error());
  if (files->handEye.config != HandEyeConfig::EyeInHand)
    return fail(Status::NotCalibrated, fmt::format("{}: configuration eye-to-hand: a fixed camera, not one on the flange",
                                                   handEyePath));
  // Whether the plane is in front of the camera depends on each snapshot: pixelToRobot has
  // no answer for a ray that misses it.
  return EyeInHandPlaneMapping(files->camera, files->handEye.x, files->plane);
}

}  // namespace vgr::vision::calib
