#include "sim/calib_scene.hpp"

#include <cmath>
#include <random>

#include <opencv2/calib3d.hpp>

#include "config/cell_config.hpp"
#include "vision/calib/plane_model.hpp"
#include "vision/calib/se3.hpp"

namespace vgr::sim {
namespace se3 = vision::se3;
using vision::calib::PatternKind;
using vision::calib::PatternSpec;

namespace {

constexpr double kDeg = M_PI / 180.0;

// Pattern gray value at plate point (x, y) mm: 0 = black, 1 = white, -1 = off the plate.
// Chessboard and circles analytically; charuco from OpenCV's board layout (markers in the
// white squares, one texel per marker bit).
class PlateTexture {
 public:
  explicit PlateTexture(const PatternSpec& s) : s_(s) {
    if (s.kind != PatternKind::Charuco) return;
    auto l = vision::calib::charucoLayout(s);
    if (!l) return;  // validated by the caller
    layout_ = std::move(*l);
    // Square (qx, qy), qx in [0, cols], qy in [0, rows], spans [(qx-1) p, qx p] x [(qy-1) p, qy p].
    squareMarker_.assign(static_cast<std::size_t>((s.cols + 1) * (s.rows + 1)), -1);
    for (std::size_t m = 0; m < layout_.markers.size(); ++m) {
      cv::Point2f c(0, 0);
      for (const auto& q : layout_.markers[m]) c += q * 0.25f;
      const int qx = static_cast<int>(std::floor(c.x / s.pitchMm)) + 1, qy = static_cast<int>(std::floor(c.y / s.pitchMm)) + 1;
      if (qx >= 0 && qy >= 0 && qx <= s.cols && qy <= s.rows)
        squareMarker_[static_cast<std::size_t>(qy * (s.cols + 1) + qx)] = static_cast<int>(m);
    }
  }

  double operator()(double x, double y) const {
    const PatternSpec& s = s_;
    const double p = s.pitchMm;
    // The plate: the pattern plus a one-pitch margin (chessboard: the outer squares + margin).
    const double lo = -2 * p, hiX = (s.cols + 1) * p, hiY = (s.rows + 1) * p;
    if (x < lo || y < lo || x > hiX || y > hiY) return -1;
    if (s.kind == PatternKind::Chessboard) {
      // Inner corner (i, j) sits at (i p, j p): squares span [-p, cols p] x [-p, rows p].
      if (x < -p || y < -p || x > s.cols * p || y > s.rows * p) return 1;
      const long ix = static_cast<long>(std::floor(x / p)), iy = static_cast<long>(std::floor(y / p));
      return ((ix + iy) & 1) ? 1 : 0;
    }
    if (s.kind == PatternKind::Charuco) {
      if (x < -p || y < -p || x >= s.cols * p || y >= s.rows * p) return 1;
      const int qx = static_cast<int>(std::floor(x / p)) + 1, qy = static_cast<int>(std::floor(y / p)) + 1;
      const int m = squareMarker_[static_cast<std::size_t>(qy * (s.cols + 1) + qx)];
      if (m < 0) return 0;  // a black square
      // Marker-image coordinates: along corner 0 -> 1 (columns) and 0 -> 3 (rows).
      const auto& c = layout_.markers[static_cast<std::size_t>(m)];
      const cv::Point2d e1 = c[1] - c[0], e3 = c[3] - c[0], d(x - c[0].x, y - c[0].y);
      const double a = d.dot(e1) / e1.dot(e1), b = d.dot(e3) / e3.dot(e3);
      if (a < 0 || b < 0 || a >= 1 || b >= 1) return 1;  // white square around the marker
      const cv::Mat& img = layout_.markerImages[static_cast<std::size_t>(m)];
      return img.at<std::uint8_t>(static_cast<int>(b * img.rows), static_cast<int>(a * img.cols)) > 127 ? 1 : 0;
    }
    const double i = std::round(x / p), j = std::round(y / p);
    if (i < 0 || j < 0 || i >= s.cols || j >= s.rows) return 1;
    const double dx = x - i * p, dy = y - j * p;
    return dx * dx + dy * dy <= 0.0625 * p * p ? 0 : 1;  // radius 0.25 pitch
  }

 private:
  PatternSpec s_;
  vision::calib::CharucoLayout layout_;
  std::vector<int> squareMarker_;  // marker index per square, -1: black square
};

}  // namespace

TrueCamera cellCamera(const config::CellConfig& cell) {
  const auto& m = cell.model;
  TrueCamera c;
  c.cameraMatrix = cv::Matx33d(m.fx, 0, m.cx, 0, m.fy, m.cy, 0, 0, 1);
  c.dist = cv::Vec<double, 5>(0, 0, 0, 0, 0);
  c.imageSize = cv::Size(cell.sim.width, cell.sim.height);
  return c;
}

Pose cellCameraMount(const config::CellConfig& cell) {
  const auto& m = cell.model;
  return vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg);
}

TrueCamera defaultCalibCamera() {
  TrueCamera c;
  c.cameraMatrix = cv::Matx33d(900.0, 0, 403.7, 0, 902.5, 296.2, 0, 0, 1);
  c.dist = cv::Vec<double, 5>(-0.12, 0.05, 0.0006, -0.0004, 0.0);
  c.imageSize = cv::Size(800, 600);
  return c;
}

cv::Mat renderPlate(const TrueCamera& cam, const PatternSpec& spec, const Pose& camFromPlate,
                    const PlateRenderOptions& o) {
  const int w = cam.imageSize.width, h = cam.imageSize.height;
  // Plate coordinates of every pixel corner (u - 0.5, v - 0.5): undistort to a normalised
  // ray, intersect with the plate plane. Sub-samples interpolate bilinearly between the four
  // corners of their pixel (the map is smooth at that scale).
  // Undistortion runs on a 4 px lattice and is interpolated bilinearly to the pixel corners:
  // the map is smooth (interpolation error ~ h^2/8 * |d2/du2| < 1e-3 px for this lens) and
  // undistortPoints costs ~0.4 us per point.
  constexpr int kStep = 4;
  const int gw = w / kStep + 2, gh = h / kStep + 2;
  std::vector<cv::Point2d> lattice;
  lattice.reserve(static_cast<std::size_t>(gw * gh));
  for (int j = 0; j < gh; ++j)
    for (int i = 0; i < gw; ++i) lattice.emplace_back(i * kStep - 0.5, j * kStep - 0.5);
  std::vector<cv::Point2d> latticeNorm;
  cv::undistortPoints(lattice, latticeNorm, cam.cameraMatrix, cam.dist, cv::noArray(), cv::noArray(),
                      cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-12));
  std::vector<cv::Point2d> norm;
  norm.reserve(static_cast<std::size_t>((w + 1) * (h + 1)));
  for (int v = 0; v <= h; ++v)
    for (int u = 0; u <= w; ++u) {
      const int i = u / kStep, j = v / kStep;
      const double fu = static_cast<double>(u - i * kStep) / kStep, fv = static_cast<double>(v - j * kStep) / kStep;
      const auto at = [&](int a, int b) { return latticeNorm[static_cast<std::size_t>(b * gw + a)]; };
      norm.push_back((1 - fu) * (1 - fv) * at(i, j) + fu * (1 - fv) * at(i + 1, j) + (1 - fu) * fv * at(i, j + 1) +
                     fu * fv * at(i + 1, j + 1));
    }
  const se3::Iso t = se3::toIso(camFromPlate);
  const Eigen::Vector3d n = t.linear().col(2), o3 = t.translation();
  const Eigen::Matrix3d rt = t.linear().transpose();
  std::vector<cv::Point2d> plate(norm.size());  // one entry per pixel corner, (w + 1) x (h + 1)
  std::vector<char> valid(norm.size(), 0);
  for (std::size_t k = 0; k < norm.size(); ++k) {
    const Eigen::Vector3d d(norm[k].x, norm[k].y, 1.0);
    const double den = n.dot(d);
    if (std::abs(den) < 1e-12) continue;
    const double s = n.dot(o3) / den;
    if (s <= 0) continue;
    const Eigen::Vector3d q = rt * (s * d - o3);
    plate[k] = {q.x(), q.y()};
    valid[k] = 1;
  }
  const PlateTexture patternValue(spec);
  cv::Mat img(h, w, CV_8UC1);
  std::mt19937_64 rng(o.seed * 0x9E3779B97F4A7C15ull + 7);
  std::normal_distribution<double> noise(0.0, o.noiseSigma);
  const int ss = std::max(1, o.supersample);
  for (int v = 0; v < h; ++v) {
    auto* row = img.ptr<std::uint8_t>(v);
    for (int u = 0; u < w; ++u) {
      const std::size_t k00 = static_cast<std::size_t>(v * (w + 1) + u), k10 = k00 + 1,
                        k01 = k00 + static_cast<std::size_t>(w + 1), k11 = k01 + 1;
      double sum = 0;
      if (valid[k00] && valid[k10] && valid[k01] && valid[k11]) {
        for (int b = 0; b < ss; ++b)
          for (int a = 0; a < ss; ++a) {
            const double fa = (a + 0.5) / ss, fb = (b + 0.5) / ss;
            const cv::Point2d p = (1 - fa) * (1 - fb) * plate[k00] + fa * (1 - fb) * plate[k10] +
                                  (1 - fa) * fb * plate[k01] + fa * fb * plate[k11];
            const double val = patternValue(p.x, p.y);
            sum += val < 0 ? o.background : o.black + val * (o.white - o.black);
          }
        sum /= ss * ss;
      } else {
        sum = o.background;
      }
      if (o.noiseSigma > 0) sum += noise(rng);
      row[u] = cv::saturate_cast<std::uint8_t>(sum);
    }
  }
  return img;
}

std::vector<cv::Point2f> projectPattern(const TrueCamera& cam, const PatternSpec& spec, const Pose& camFromPlate) {
  cv::Vec3d rvec, tvec;
  se3::toRvecTvec(se3::toIso(camFromPlate), rvec, tvec);
  std::vector<cv::Point2f> out;
  cv::projectPoints(vision::calib::patternObjectPoints(spec), rvec, tvec, cam.cameraMatrix, cam.dist, out);
  return out;
}

std::vector<cv::Point2f> addCornerNoise(const std::vector<cv::Point2f>& truth, double sigmaPx, std::uint64_t seed) {
  std::mt19937_64 rng(seed * 0xBF58476D1CE4E5B9ull + 3);
  std::normal_distribution<double> nd(0.0, sigmaPx);
  std::vector<cv::Point2f> out = truth;
  if (sigmaPx <= 0) return out;
  for (auto& p : out) {
    p.x += static_cast<float>(nd(rng));
    p.y += static_cast<float>(nd(rng));
  }
  return out;
}

vision::calib::ViewDetection visiblePattern(const TrueCamera& cam, const PatternSpec& spec, const Pose& camFromPlate,
                                           double marginPx, const std::string& name) {
  vision::calib::ViewDetection d;
  d.name = name;
  const se3::Iso t = se3::toIso(camFromPlate);
  const auto obj = vision::calib::patternObjectPoints(spec);
  const auto img = projectPattern(cam, spec, camFromPlate);
  for (std::size_t i = 0; i < obj.size(); ++i) {
    if ((t * Eigen::Vector3d(obj[i].x, obj[i].y, obj[i].z)).z() < 50) continue;
    const cv::Point2f q = img[i];
    if (q.x < marginPx || q.y < marginPx || q.x > cam.imageSize.width - 1 - marginPx ||
        q.y > cam.imageSize.height - 1 - marginPx)
      continue;
    d.corners.push_back(q);
    d.ids.push_back(static_cast<int>(i));
  }
  d.found = static_cast<int>(d.corners.size()) >= vision::calib::kMinCharucoCorners;
  return d;
}

std::vector<Pose> randomPlateViews(const TrueCamera& cam, const PatternSpec& spec, int n, std::uint64_t seed,
                                   double distanceMm, double maxTiltDeg, double marginPx, double partialShare) {
  std::mt19937_64 rng(seed * 0x94D049BB133111EBull + 11);
  std::uniform_real_distribution<double> uni(-1.0, 1.0);
  const double fx = cam.cameraMatrix(0, 0), fy = cam.cameraMatrix(1, 1);
  const double cx = cam.cameraMatrix(0, 2), cy = cam.cameraMatrix(1, 2);
  const Eigen::Vector3d centre((spec.cols - 1) * spec.pitchMm / 2, (spec.rows - 1) * spec.pitchMm / 2, 0);
  const auto obj = vision::calib::patternObjectPoints(spec);
  std::vector<Pose> views;
  int partialMade = 0;
  for (int attempt = 0; static_cast<int>(views.size()) < n && attempt < 20000; ++attempt) {
    const int k = static_cast<int>(views.size());
    // Partial views spread evenly through the set: view k is partial when the running share
    // of partial views would otherwise fall behind partialShare.
    const bool partial = partialMade < static_cast<int>(std::floor((k + 1) * partialShare + 1e-9));
    // Aim the plate centre at one of 9 image regions in turn (corners included), jittered.
    // The offset shrinks at random so that large plates still fit. Partial views do the same
    // with a plate larger than the field of view at that distance: it fills the frame, image
    // corners included, and sticks out on one side or more.
    const int region = partial ? partialMade % 9 : k % 9;
    const double reach = partial ? 0.4 * std::abs(uni(rng)) : 0.3 * (0.5 + 0.5 * std::abs(uni(rng)));
    const double u = cx + (region % 3 - 1) * reach * cam.imageSize.width + uni(rng) * 0.05 * cam.imageSize.width;
    const double v = cy + (region / 3 - 1) * reach * cam.imageSize.height + uni(rng) * 0.05 * cam.imageSize.height;
    const double d = distanceMm * (1.0 + 0.2 * uni(rng));
    const Eigen::Matrix3d r = (Eigen::AngleAxisd(30 * kDeg * uni(rng), Eigen::Vector3d::UnitZ()) *
                               Eigen::AngleAxisd(maxTiltDeg * kDeg * uni(rng), Eigen::Vector3d::UnitY()) *
                               Eigen::AngleAxisd(maxTiltDeg * kDeg * uni(rng), Eigen::Vector3d::UnitX()))
                                  .toRotationMatrix();
    se3::Iso t = se3::Iso::Identity();
    t.linear() = r;
    t.translation() = Eigen::Vector3d((u - cx) / fx * d, (v - cy) / fy * d, d) - r * centre;
    // Every pattern point (and the outer squares) in front of the camera.
    bool ok = true;
    for (const auto& p : obj)
      if ((t * Eigen::Vector3d(p.x, p.y, p.z)).z() < 50) ok = false;
    if (!ok) continue;
    const Pose pose = se3::toPose(t);
    if (partial) {
      // At least 30 % of the points inside the image (10 px margin), at least one outside.
      const auto seen = visiblePattern(cam, spec, pose, 10.0, "");
      if (seen.corners.size() < std::max<std::size_t>(12, obj.size() * 3 / 10) || seen.corners.size() == obj.size())
        continue;
      ++partialMade;
      views.push_back(pose);
      continue;
    }
    // Full views: the pattern and its outer squares inside the image with marginPx.
    PatternSpec outer = spec;  // the pattern grown by one pitch on each side
    outer.cols += 2;
    outer.rows += 2;
    se3::Iso shifted = t * Eigen::Translation3d(-spec.pitchMm, -spec.pitchMm, 0);
    for (const auto& q : projectPattern(cam, outer, se3::toPose(shifted)))
      if (q.x < marginPx || q.y < marginPx || q.x > cam.imageSize.width - 1 - marginPx ||
          q.y > cam.imageSize.height - 1 - marginPx)
        ok = false;
    if (ok) views.push_back(pose);
  }
  return views;
}

HandEyeScenario makeHandEyeScenario(vision::calib::HandEyeConfig config, const TrueCamera& cam,
                                    const PatternSpec& spec, int n, std::uint64_t seed, double robotNoiseMm,
                                    double robotNoiseDeg, const std::optional<Pose>& fixedX, double distanceMm) {
  HandEyeScenario s;
  s.config = config;
  se3::Iso x = se3::Iso::Identity(), y = se3::Iso::Identity();
  if (config == vision::calib::HandEyeConfig::EyeInHand) {
    // Camera on the flange, 80 mm out and offset; plate on the table.
    x.linear() = (Eigen::AngleAxisd(1.2, Eigen::Vector3d(0.1, 0.2, 1.0).normalized())).toRotationMatrix();
    x.translation() = Eigen::Vector3d(32.5, -61.0, 84.0);
    y.linear() = Eigen::AngleAxisd(20 * kDeg, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    y.translation() = Eigen::Vector3d(520.0, 110.0, 3.0);
  } else {
    // Camera above the cell looking down (tilted 5 deg); plate held by the gripper.
    x.linear() = (Eigen::AngleAxisd(90 * kDeg, Eigen::Vector3d::UnitZ()) *
                  Eigen::AngleAxisd(M_PI + 5 * kDeg, Eigen::Vector3d::UnitX()))
                     .toRotationMatrix();
    x.translation() = Eigen::Vector3d(400.0, 20.0, 900.0);
    y.linear() = Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.3, -0.4, 1.0).normalized()).toRotationMatrix();
    y.translation() = Eigen::Vector3d(-75.0, -52.0, 41.0);
  }
  if (fixedX) x = se3::toIso(*fixedX);
  s.x = se3::toPose(x);
  s.y = se3::toPose(y);
  s.camFromPlate = randomPlateViews(cam, spec, n, seed, distanceMm);
  std::mt19937_64 rng(seed * 0xD6E8FEB86659FD93ull + 5);
  std::normal_distribution<double> nt(0.0, robotNoiseMm), nr(0.0, robotNoiseDeg * kDeg);
  for (const auto& b : s.camFromPlate) {
    const se3::Iso bi = se3::toIso(b);
    const se3::Iso a = config == vision::calib::HandEyeConfig::EyeInHand ? se3::Iso(y * bi.inverse() * x.inverse())
                                                                          : se3::Iso(x * bi * y.inverse());
    s.robotTrue.push_back(se3::toPose(a));
    se3::Iso noisy = a;
    const Eigen::Vector3d dphi(nr(rng), nr(rng), nr(rng));
    const Eigen::Vector3d dt(nt(rng), nt(rng), nt(rng));
    if (dphi.norm() > 0) noisy.linear() = Eigen::AngleAxisd(dphi.norm(), dphi.normalized()).toRotationMatrix() * a.linear();
    noisy.translation() += dt;
    s.robotReported.push_back(se3::toPose(noisy));
  }
  return s;
}

}  // namespace vgr::sim
