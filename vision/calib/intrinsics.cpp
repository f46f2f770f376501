#include "vision/calib/intrinsics.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <fmt/core.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/imgproc.hpp>

namespace vgr::vision::calib {
namespace {

double viewRms(const std::vector<cv::Point3f>& obj, const std::vector<cv::Point2f>& img, const cv::Vec3d& rvec,
               const cv::Vec3d& tvec, const cv::Matx33d& k, const cv::Vec<double, 5>& d) {
  std::vector<cv::Point2f> proj;
  cv::projectPoints(obj, rvec, tvec, k, d, proj);
  double s = 0;
  for (std::size_t i = 0; i < img.size(); ++i) {
    const cv::Point2f e = proj[i] - img[i];
    s += e.x * e.x + e.y * e.y;
  }
  return std::sqrt(s / static_cast<double>(img.size()));
}

double tiltDeg(const cv::Vec3d& rvec) {
  cv::Matx33d r;
  cv::Rodrigues(rvec, r);
  return std::acos(std::min(1.0, std::abs(r(2, 2)))) * 180.0 / M_PI;
}

double median(std::vector<double> v) {
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

}  // namespace

Result<PatternKind> parsePatternKind(const std::string& name) {
  if (name == "chessboard") return PatternKind::Chessboard;
  if (name == "circles") return PatternKind::Circles;
  if (name == "charuco")
    return fail(Status::BadArgument,
                "pattern 'charuco' is not implemented yet (use chessboard or circles); see docs/calibration.md");
  return fail(Status::BadArgument, fmt::format("unknown pattern '{}': expected chessboard or circles", name));
}

const char* patternKindName(PatternKind k) { return k == PatternKind::Chessboard ? "chessboard" : "circles"; }

std::vector<cv::Point3f> patternObjectPoints(const PatternSpec& spec) {
  std::vector<cv::Point3f> pts;
  pts.reserve(static_cast<std::size_t>(spec.cols * spec.rows));
  for (int j = 0; j < spec.rows; ++j)
    for (int i = 0; i < spec.cols; ++i)
      pts.emplace_back(static_cast<float>(i * spec.pitchMm), static_cast<float>(j * spec.pitchMm), 0.f);
  return pts;
}

ViewDetection detectPattern(const cv::Mat& gray, const PatternSpec& spec, const std::string& name) {
  ViewDetection d;
  d.name = name;
  const cv::Size size(spec.cols, spec.rows);
  if (spec.kind == PatternKind::Chessboard) {
    d.found = cv::findChessboardCorners(gray, size, d.corners,
                                        cv::CALIB_CB_ADAPTIVE_THRESH | cv::CALIB_CB_NORMALIZE_IMAGE);
    if (d.found)
      cv::cornerSubPix(gray, d.corners, cv::Size(5, 5), cv::Size(-1, -1),
                       cv::TermCriteria(cv::TermCriteria::EPS + cv::TermCriteria::COUNT, 100, 1e-4));
  } else {
    d.found = cv::findCirclesGrid(gray, size, d.corners, cv::CALIB_CB_SYMMETRIC_GRID);
  }
  if (!d.found) d.corners.clear();
  return d;
}

Result<IntrinsicsResult> calibrateIntrinsics(const std::vector<ViewDetection>& views, const PatternSpec& spec,
                                             cv::Size imageSize, const IntrinsicsOptions& options) {
  const std::vector<cv::Point3f> obj = patternObjectPoints(spec);
  std::vector<const ViewDetection*> usable;
  std::vector<std::string> missing;
  for (const auto& v : views) {
    if (!v.found) {
      missing.push_back(v.name);
      continue;
    }
    if (v.corners.size() != obj.size())
      return fail(Status::BadArgument, fmt::format("view '{}': {} points detected, the {}x{} pattern has {}", v.name,
                                                   v.corners.size(), spec.cols, spec.rows, obj.size()));
    usable.push_back(&v);
  }
  if (static_cast<int>(usable.size()) < options.minViews) {
    std::string list;
    for (const auto& m : missing) list += (list.empty() ? "" : ", ") + m;
    return fail(Status::BadArgument,
                fmt::format("too few views: the {} {}x{} was found in {} of {} views, {} needed{}{}",
                            patternKindName(spec.kind), spec.cols, spec.rows, usable.size(), views.size(),
                            options.minViews, missing.empty() ? "" : "; not found in: ", list));
  }

  IntrinsicsResult res;
  std::vector<bool> active(usable.size(), true);
  for (int round = 0; round < 5; ++round) {
    std::vector<std::vector<cv::Point3f>> objs;
    std::vector<std::vector<cv::Point2f>> imgs;
    std::vector<std::size_t> idx;
    for (std::size_t i = 0; i < usable.size(); ++i)
      if (active[i]) {
        objs.push_back(obj);
        imgs.push_back(usable[i]->corners);
        idx.push_back(i);
      }
    cv::Mat k, d;
    std::vector<cv::Mat> rv, tv;
    try {
      res.camera.rmsPx = cv::calibrateCamera(objs, imgs, imageSize, k, d, rv, tv, 0,
                                             cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 100, 1e-12));
    } catch (const cv::Exception& e) {
      return fail(Status::BadArgument, fmt::format("calibrateCamera failed on {} views: {}", idx.size(), e.what()));
    }
    res.camera.cameraMatrix = cv::Matx33d(k);
    for (int c = 0; c < 5; ++c) res.camera.dist[c] = d.at<double>(c);
    res.camera.imageSize = imageSize;
    res.camera.views.clear();
    res.rvecs.clear();
    res.tvecs.clear();
    res.usedViews.clear();
    std::vector<double> errs;
    for (std::size_t n = 0; n < idx.size(); ++n) {
      const cv::Vec3d r(rv[n]), t(tv[n]);
      const double e = viewRms(obj, imgs[n], r, t, res.camera.cameraMatrix, res.camera.dist);
      errs.push_back(e);
      res.camera.views.push_back({usable[idx[n]]->name, e, tiltDeg(r), true});
      res.rvecs.push_back(r);
      res.tvecs.push_back(t);
      res.usedViews.push_back(usable[idx[n]]->name);
    }
    // Outliers: views far above the median error. Remove the worst one per round and re-solve
    // (removing all at once can throw away good views that a single bad one dragged up).
    const double limit = std::max(options.outlierFactor * median(errs), options.outlierFloorPx);
    std::size_t worst = 0;
    for (std::size_t n = 1; n < errs.size(); ++n)
      if (errs[n] > errs[worst]) worst = n;
    if (errs[worst] <= limit || static_cast<int>(idx.size()) <= options.minViews) break;
    active[idx[worst]] = false;
    res.rejectedViews.push_back(fmt::format("{} ({:.3f} px > {:.3f} px)", usable[idx[worst]]->name, errs[worst], limit));
  }
  for (std::size_t i = 0; i < usable.size(); ++i)
    if (!active[i]) res.camera.views.push_back({usable[i]->name, -1, 0, false});

  // Coverage: which cells of an 8 x 8 image grid hold a corner of some used view.
  bool cells[8][8] = {};
  for (std::size_t i = 0; i < usable.size(); ++i) {
    if (!active[i]) continue;
    for (const auto& p : usable[i]->corners) {
      const int cx = std::clamp(static_cast<int>(p.x * 8 / imageSize.width), 0, 7);
      const int cy = std::clamp(static_cast<int>(p.y * 8 / imageSize.height), 0, 7);
      cells[cy][cx] = true;
    }
  }
  int filled = 0;
  for (auto& row : cells)
    for (bool c : row) filled += c;
  auto& cov = res.coverage;
  cov.imageCoverage = filled / 64.0;
  cov.minTiltDeg = 90;
  cov.maxTiltDeg = 0;
  for (const auto& v : res.camera.views)
    if (v.used) cov.minTiltDeg = std::min(cov.minTiltDeg, v.tiltDeg), cov.maxTiltDeg = std::max(cov.maxTiltDeg, v.tiltDeg);
  if (cov.imageCoverage < 0.6)
    cov.advice.push_back(fmt::format("corners cover {:.0f} % of the image: add views with the plate near the "
                                     "corners and edges (distortion is largest there)",
                                     cov.imageCoverage * 100));
  if (cov.maxTiltDeg < 20)
    cov.advice.push_back(fmt::format("largest plate tilt is {:.1f} deg: add views tilted 20-45 deg (focal length "
                                     "is poorly determined from fronto-parallel views)",
                                     cov.maxTiltDeg));
  if (res.usedViews.size() < 10)
    cov.advice.push_back(fmt::format("{} views used: 10-20 are recommended", res.usedViews.size()));
  return res;
}

Result<void> writeIntrinsics(const std::string& path, const CameraIntrinsics& cam) {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot open for writing", path));
    fs << "calibration_kind" << "intrinsics";
    fs << "image_width" << cam.imageSize.width << "image_height" << cam.imageSize.height;
    fs << "camera_matrix" << cv::Mat(cam.cameraMatrix);
    fs << "distortion_coefficients" << cv::Mat(cam.dist);
    fs << "rms_px" << cam.rmsPx;
    fs << "views" << "[";
    for (const auto& v : cam.views)
      fs << "{" << "name" << v.name << "rms_px" << v.rmsPx << "tilt_deg" << v.tiltDeg << "used" << (v.used ? 1 : 0) << "}";
    fs << "]";
  } catch (const cv::Exception& e) {
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  return {};
}

Result<CameraIntrinsics> readIntrinsics(const std::string& path) {
  CameraIntrinsics cam;
  if (!std::filesystem::exists(path)) return fail(Status::NotCalibrated, fmt::format("{}: no such intrinsics file", path));
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return fail(Status::NotCalibrated, fmt::format("{}: cannot open intrinsics file", path));
    cv::Mat k, d;
    fs["camera_matrix"] >> k;
    fs["distortion_coefficients"] >> d;
    if (k.rows != 3 || k.cols != 3)
      return fail(Status::NotCalibrated, fmt::format("{}: key 'camera_matrix': missing or not 3x3", path));
    if (d.total() != 5)
      return fail(Status::NotCalibrated, fmt::format("{}: key 'distortion_coefficients': expected 5 values", path));
    k.convertTo(k, CV_64F);
    d.convertTo(d, CV_64F);
    cam.cameraMatrix = cv::Matx33d(k);
    for (int i = 0; i < 5; ++i) cam.dist[i] = d.at<double>(i);
    cam.imageSize = cv::Size(static_cast<int>(fs["image_width"]), static_cast<int>(fs["image_height"]));
    cam.rmsPx = static_cast<double>(fs["rms_px"]);
    const cv::FileNode views = fs["views"];
    for (const auto& n : views)
      cam.views.push_back({static_cast<std::string>(n["name"]), static_cast<double>(n["rms_px"]),
                           static_cast<double>(n["tilt_deg"]), static_cast<int>(n["used"]) != 0});
  } catch (const cv::Exception& e) {
    return fail(Status::NotCalibrated, fmt::format("{}: {}", path, e.what()));
  }
  if (!(cam.fx() > 0 && cam.fy() > 0) || cam.imageSize.width <= 0 || cam.imageSize.height <= 0)
    return fail(Status::NotCalibrated, fmt::format("{}: focal lengths and image size must be positive", path));
  return cam;
}

}  // namespace vgr::vision::calib
