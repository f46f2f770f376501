#include "vision/cloud/cloud_math.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>

#include <Eigen/Geometry>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "vision/cloud/locator3d.hpp"

namespace vgr::vision::cloud {

Eigen::Matrix4d toMatrix(const Pose& p) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz).normalized().toRotationMatrix();
  t.topRightCorner<3, 1>() = Eigen::Vector3d(p.x, p.y, p.z);
  return t;
}

Pose toPose(const Eigen::Matrix4d& t) {
  Eigen::Quaterniond q(Eigen::Matrix3d(t.topLeftCorner<3, 3>()));
  q.normalize();
  if (q.w() < 0) q.coeffs() *= -1.0;
  return Pose{t(0, 3), t(1, 3), t(2, 3), q.w(), q.x(), q.y(), q.z()};
}

std::vector<Eigen::Vector3d> backProject(const cv::Mat& depthMm, const DepthIntrinsics& k, const RoiBox& roi, int step) {
  std::vector<Eigen::Vector3d> out;
  out.reserve(depthMm.total() / static_cast<std::size_t>(step * step));
  for (int v = 0; v < depthMm.rows; v += step) {
    const float* row = depthMm.ptr<float>(v);
    const double y0 = (v - k.cy) / k.fy;
    for (int u = 0; u < depthMm.cols; u += step) {
      const double z = row[u];
      if (!(z > 0)) continue;
      const Eigen::Vector3d p((u - k.cx) / k.fx * z, y0 * z, z);
      if (p.x() < roi.xMin || p.x() > roi.xMax || p.y() < roi.yMin || p.y() > roi.yMax || z < roi.zMin || z > roi.zMax) continue;
      out.push_back(p);
    }
  }
  return out;
}

VisibilityCheck::VisibilityCheck(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals, double spacingMm)
    : points_(std::move(points)), normals_(std::move(normals)), spacingMm_(spacingMm) {
  front_.reserve(points_.size());
}

Visibility VisibilityCheck::check(const Eigen::Matrix4d& t, const cv::Mat& depth, const DepthIntrinsics& k, double tol,
                                  double maxAngleDeg, const cv::Mat& claimed) {
  Visibility out;
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
  const double cosMin = std::cos(maxAngleDeg * M_PI / 180.0);
  const int w = depth.cols, h = depth.rows;
  // Front-facing points inside the image, and the box they cover.
  front_.clear();
  int u0 = w, u1 = -1, v0 = h, v1 = -1;
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const Eigen::Vector3d p = r * points_[i] + tr;
    if (p.z() <= 1) continue;
    const Eigen::Vector3d n = r * normals_[i];
    if (-n.dot(p) < cosMin * p.norm()) continue;  // back-facing or grazing
    const double u = k.fx * p.x() / p.z() + k.cx, v = k.fy * p.y() / p.z() + k.cy;
    const int ui = static_cast<int>(std::lround(u)), vi = static_cast<int>(std::lround(v));
    if (ui < 0 || vi < 0 || ui >= w || vi >= h) {
      ++out.outside;
      continue;
    }
    front_.emplace_back(ui, vi, p.z(), static_cast<double>(i));
    u0 = std::min(u0, ui), u1 = std::max(u1, ui), v0 = std::min(v0, vi), v1 = std::max(v1, vi);
  }
  if (front_.empty()) return out;
  // The model's own z-buffer over that box: each point splatted as a square about its
  // spacing wide, so a point behind another part of the model is not expected to be seen.
  if (zbuf_.rows != h || zbuf_.cols != w) zbuf_.create(h, w, CV_32FC1);
  const cv::Rect box(u0, v0, u1 - u0 + 1, v1 - v0 + 1);
  zbuf_(box).setTo(std::numeric_limits<float>::infinity());
  for (const auto& f : front_) {
    const int rad = std::max(1, static_cast<int>(std::lround(0.6 * spacingMm_ * k.fx / f[2])));
    const int ui = static_cast<int>(f[0]), vi = static_cast<int>(f[1]);
    for (int y = std::max(v0, vi - rad); y <= std::min(v1, vi + rad); ++y) {
      float* zr = zbuf_.ptr<float>(y);
      for (int x = std::max(u0, ui - rad); x <= std::min(u1, ui + rad); ++x) zr[x] = std::min(zr[x], static_cast<float>(f[2]));
    }
  }
  const double selfTol = 1.5 * spacingMm_;
  for (const auto& f : front_) {
    const int ui = static_cast<int>(f[0]), vi = static_cast<int>(f[1]);
    const double z = f[2];
    if (zbuf_.at<float>(vi, ui) < z - selfTol) continue;  // hidden by the model itself
    const std::uint8_t mark = claimed.empty() ? kPixelFree : claimed.at<std::uint8_t>(vi, ui);
    if (mark == kPixelClaimed) {
      ++out.unknown;  // another part found before explains this pixel
      continue;
    }
    bool matched = false, anyValid = false, allBehind = true;
    for (int y = std::max(0, vi - 1); y <= std::min(h - 1, vi + 1) && !matched; ++y) {
      const float* dr = depth.ptr<float>(y);
      for (int x = std::max(0, ui - 1); x <= std::min(w - 1, ui + 1); ++x) {
        const double d = dr[x];
        if (!(d > 0)) continue;
        anyValid = true;
        if (std::abs(d - z) <= tol) {
          matched = true;
          break;
        }
        if (d <= z + tol) allBehind = false;
      }
    }
    if (matched && mark == kPixelPlane) ++out.unknown;  // the table: no evidence of a part
    else if (matched) ++out.matched;
    else if (!anyValid) ++out.unknown;
    else if (allBehind) ++out.contradicted;
    else ++out.occluded;  // something nearer in the neighbourhood
  }
  const int n = out.matched + out.occluded + out.contradicted;
  if (n > 0) {
    out.fitness = static_cast<double>(out.matched) / n;
    out.contradiction = static_cast<double>(out.contradicted) / n;
  }
  // The ring just outside the model's silhouette (kRingMm wide): where the measured surface
  // there lies within tol of the nearest model z, the surface runs on past the part's edge.
  double zSum = 0;
  for (const auto& f : front_) zSum += f[2];
  const int ring = std::max(2, static_cast<int>(std::lround(kRingMm * k.fx * static_cast<double>(front_.size()) / zSum)));
  const cv::Rect outer = cv::Rect(u0 - ring, v0 - ring, box.width + 2 * ring, box.height + 2 * ring) & cv::Rect(0, 0, w, h);
  ringIn_.create(outer.size(), CV_32FC1);
  ringIn_.setTo(std::numeric_limits<float>::infinity());
  zbuf_(box).copyTo(ringIn_(box - outer.tl()));
  cv::erode(ringIn_, ringNear_, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(2 * ring + 1, 2 * ring + 1)));  // min filter
  int ringValid = 0, continued = 0;
  for (int y = 0; y < outer.height; ++y) {
    const float* in = ringIn_.ptr<float>(y);
    const float* nearZ = ringNear_.ptr<float>(y);
    const float* dr = depth.ptr<float>(outer.y + y) + outer.x;
    for (int x = 0; x < outer.width; ++x) {
      if (std::isfinite(in[x]) || !std::isfinite(nearZ[x]) || !(dr[x] > 0)) continue;
      if (!claimed.empty() && claimed.at<std::uint8_t>(outer.y + y, outer.x + x) == kPixelClaimed) continue;
      ++ringValid;
      if (std::abs(dr[x] - nearZ[x]) <= tol) ++continued;
    }
  }
  out.continuation = ringValid > 0 ? static_cast<double>(continued) / ringValid : 0;
  return out;
}

std::vector<std::size_t> VisibilityCheck::visibleSet(const Eigen::Matrix4d& t, const cv::Mat& depth, const DepthIntrinsics& k,
                                                    double maxAngleDeg) {
  // The same front-facing, in-image, not-self-hidden test as check().
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
  const double cosMin = std::cos(maxAngleDeg * M_PI / 180.0);
  const int w = depth.cols, h = depth.rows;
  front_.clear();
  int u0 = w, u1 = -1, v0 = h, v1 = -1;
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const Eigen::Vector3d p = r * points_[i] + tr;
    if (p.z() <= 1 || -(r * normals_[i]).dot(p) < cosMin * p.norm()) continue;
    const int ui = static_cast<int>(std::lround(k.fx * p.x() / p.z() + k.cx)), vi = static_cast<int>(std::lround(k.fy * p.y() / p.z() + k.cy));
    if (ui < 0 || vi < 0 || ui >= w || vi >= h) continue;
    front_.emplace_back(ui, vi, p.z(), static_cast<double>(i));
    u0 = std::min(u0, ui), u1 = std::max(u1, ui), v0 = std::min(v0, vi), v1 = std::max(v1, vi);
  }
  std::vector<std::size_t> out;
  if (front_.empty()) return out;
  if (zbuf_.rows != h || zbuf_.cols != w) zbuf_.create(h, w, CV_32FC1);
  zbuf_(cv::Rect(u0, v0, u1 - u0 + 1, v1 - v0 + 1)).setTo(std::numeric_limits<float>::infinity());
  for (const auto& f : front_) {
    const int rad = std::max(1, static_cast<int>(std::lround(0.6 * spacingMm_ * k.fx / f[2])));
    const int ui = static_cast<int>(f[0]), vi = static_cast<int>(f[1]);
    for (int y = std::max(v0, vi - rad); y <= std::min(v1, vi + rad); ++y) {
      float* zr = zbuf_.ptr<float>(y);
      for (int x = std::max(u0, ui - rad); x <= std::min(u1, ui + rad); ++x) zr[x] = std::min(zr[x], static_cast<float>(f[2]));
    }
  }
  for (const auto& f : front_)
    if (zbuf_.at<float>(static_cast<int>(f[1]), static_cast<int>(f[0])) >= f[2] - 1.5 * spacingMm_) out.push_back(static_cast<std::size_t>(f[3]));
  return out;
}

Eigen::Matrix4d VisibilityCheck::alignToBoundaries(const Eigen::Matrix4d& start, const Eigen::Vector3d& modelCentroid,
                                                   double radiusMm, const std::vector<Eigen::Matrix<double, 6, 1>>& directions,
                                                   const std::vector<double>& stiffness, const cv::Mat& depth, const DepthIntrinsics& k, double tol, double maxAngleDeg,
                                                   const cv::Mat& claimed) {
  const std::vector<std::size_t> sel = visibleSet(start, depth, k, maxAngleDeg);
  if (sel.size() < 20) return start;
  const int w = depth.cols, h = depth.rows;
  auto cost = [&](const Eigen::Matrix4d& t) {
    const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
    const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
    double e = 0;
    for (std::size_t i : sel) {
      const Eigen::Vector3d p = r * points_[i] + tr;
      const int u = static_cast<int>(std::lround(k.fx * p.x() / p.z() + k.cx)), v = static_cast<int>(std::lround(k.fy * p.y() / p.z() + k.cy));
      if (u < 0 || v < 0 || u >= w || v >= h || (!claimed.empty() && claimed.at<std::uint8_t>(v, u) == kPixelClaimed)) {
        e += 0.25;
        continue;
      }
      double d = depth.at<float>(v, u);
      if (!(d > 0)) {  // invalid: the valid 4-neighbour nearest to the point's z decides
        double best = std::numeric_limits<double>::infinity();
        const int nb[4][2] = {{1, 0}, {-1, 0}, {0, 1}, {0, -1}};
        for (const auto& o : nb) {
          const int x = u + o[0], y = v + o[1];
          if (x < 0 || y < 0 || x >= w || y >= h) continue;
          const double dn = depth.at<float>(y, x);
          if (dn > 0 && std::abs(dn - p.z()) < std::abs(best - p.z())) best = dn;
        }
        if (!std::isfinite(best)) {
          e += 0.25;
          continue;
        }
        d = best;
      }
      const double res = d - p.z();
      if (std::abs(res) <= tol) e += 0.25 * (res / tol) * (res / tol);
      else e += res < 0 ? 0.25 : 1.0;
    }
    return e;
  };
  std::vector<Eigen::Matrix<double, 6, 1>> dirs = directions;
  if (dirs.empty())
    for (int a = 0; a < 6; ++a) dirs.push_back(Eigen::Matrix<double, 6, 1>::Unit(a));
  std::vector<double> moved(dirs.size(), 0.0);  // mm along each direction so far
  auto spring = [&](std::size_t i, double a) { return i < stiffness.size() ? stiffness[i] * a * a : 0.0; };
  Eigen::Matrix4d t = start;
  double e = cost(t);
  for (double step : {0.8, 0.4, 0.2, 0.1, 0.05}) {
    for (int pass = 0; pass < 20; ++pass) {
      bool improved = false;
      for (std::size_t di = 0; di < dirs.size(); ++di)
        for (int sign : {-1, 1}) {
          const auto& dir = dirs[di];
          // A motion of `step` mm along dir: rotation (scaled by the radius) about the
          // centroid, then the translation.
          const Eigen::Vector3d c = (t * modelCentroid.homogeneous()).head<3>();
          const Eigen::Vector3d rv = dir.head<3>() * (sign * step / radiusMm);
          Eigen::Matrix4d d = Eigen::Matrix4d::Identity();
          if (rv.norm() > 0) {
            const Eigen::Matrix3d rot = Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
            d.topLeftCorner<3, 3>() = rot;
            d.topRightCorner<3, 1>() = c - rot * c;
          }
          d.topRightCorner<3, 1>() += dir.tail<3>() * (sign * step);
          const Eigen::Matrix4d t2 = d * t;
          const double a2 = moved[di] + sign * step;
          const double e2 = cost(t2) + spring(di, a2) - spring(di, moved[di]);
          if (e2 < e - 1e-9) {
            e = e2;
            t = t2;
            moved[di] = a2;
            improved = true;
          }
        }
      if (!improved) break;
    }
  }
  return t;
}

Eigen::Matrix4d VisibilityCheck::alignToEdges(const Eigen::Matrix4d& start, const Eigen::Vector3d& modelCentroid, double radiusMm,
                                              const std::vector<Eigen::Matrix<double, 6, 1>>& directions,
                                              const std::vector<double>& stiffness, const cv::Mat& depth, const DepthIntrinsics& k,
                                              double maxAngleDeg, double edgeSigmaPx, const cv::Mat& claimed) {
  constexpr double kJumpMm = 3, kTruncPx = 3;
  constexpr int kMarginPx = 12;
  const std::vector<std::size_t> sel = visibleSet(start, depth, k, maxAngleDeg);
  if (sel.size() < 20 || directions.empty()) return start;
  const int w = depth.cols, h = depth.rows;
  // The model's contour: visible points with an empty or much deeper model pixel 2 px away.
  int u0 = w, u1 = -1, v0 = h, v1 = -1;  // the z-buffer's valid box (visibleSet fills only the front points' box)
  std::vector<std::size_t> rim;
  {
    std::map<std::size_t, std::pair<int, int>> px;
    for (const auto& f : front_) {
      const int u = static_cast<int>(f[0]), v = static_cast<int>(f[1]);
      px[static_cast<std::size_t>(f[3])] = {u, v};
      u0 = std::min(u0, u), u1 = std::max(u1, u), v0 = std::min(v0, v), v1 = std::max(v1, v);
    }
    const int off[8][2] = {{2, 0}, {-2, 0}, {0, 2}, {0, -2}, {2, 2}, {-2, -2}, {2, -2}, {-2, 2}};
    for (std::size_t i : sel) {
      const auto [u, v] = px[i];
      const float zc = zbuf_.at<float>(v, u);
      bool edge = false;
      for (const auto& o : off) {
        const int x = u + o[0], y = v + o[1];
        if (x < u0 || y < v0 || x > u1 || y > v1) { edge = true; break; }
        const float zn = zbuf_.at<float>(y, x);
        if (!std::isfinite(zn) || zn > zc + kJumpMm) { edge = true; break; }
      }
      if (edge) rim.push_back(i);
    }
  }
  if (rim.size() < 20) return start;
  // The measured edges around the part and their distance transform.
  const cv::Rect box = cv::Rect(u0 - kMarginPx, v0 - kMarginPx, u1 - u0 + 1 + 2 * kMarginPx, v1 - v0 + 1 + 2 * kMarginPx) & cv::Rect(0, 0, w, h);
  edges_.create(box.height, box.width, CV_8UC1);
  edges_.setTo(255);  // distanceTransform: distance to the nearest 0
  auto z = [&](int x, int y) -> double { return depth.at<float>(y, x); };
  auto bandInvalid = [&](int x, int y) {  // an invalid pixel with >= 2 invalid 8-neighbours (not isolated dropout)
    if (z(x, y) > 0) return false;
    int n = 0;
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        const int xx = x + dx, yy = y + dy;
        if ((dx || dy) && xx >= 0 && yy >= 0 && xx < w && yy < h && !(z(xx, yy) > 0)) ++n;
      }
    return n >= 2;
  };
  for (int y = box.y; y < box.y + box.height; ++y)
    for (int x = box.x; x < box.x + box.width; ++x) {
      const double zc = z(x, y);
      if (!(zc > 0)) continue;
      if (!claimed.empty() && claimed.at<std::uint8_t>(y, x) != kPixelFree) continue;
      bool edge = false;
      for (int dy = -1; dy <= 1 && !edge; ++dy)
        for (int dx = -1; dx <= 1 && !edge; ++dx) {
          const int xx = x + dx, yy = y + dy;
          if (!(dx || dy) || xx < 0 || yy < 0 || xx >= w || yy >= h) continue;
          const double zn = z(xx, yy);
          if (zn > zc + kJumpMm) edge = true;
          else if (!(zn > 0) && bandInvalid(xx, yy)) {
            // across the band: deeper or nothing valid 3 px on -> this pixel is the near side
            const int x3 = std::clamp(x + 3 * dx, 0, w - 1), y3 = std::clamp(y + 3 * dy, 0, h - 1);
            const double zf = z(x3, y3);
            edge = !(zf > 0) || zf > zc + kJumpMm;
          }
        }
      if (edge) edges_.at<std::uint8_t>(y - box.y, x - box.x) = 0;
    }
  cv::distanceTransform(edges_, edgeDist_, cv::DIST_L2, cv::DIST_MASK_PRECISE, CV_32F);
  auto dist = [&](double u, double v) {  // bilinear, in px, truncated
    const double x = u - box.x, y = v - box.y;
    if (x < 0 || y < 0 || x >= box.width - 1 || y >= box.height - 1) return kTruncPx;
    const int xi = static_cast<int>(x), yi = static_cast<int>(y);
    const double fx = x - xi, fy = y - yi;
    const double d = (1 - fy) * ((1 - fx) * edgeDist_.at<float>(yi, xi) + fx * edgeDist_.at<float>(yi, xi + 1)) +
                     fy * ((1 - fx) * edgeDist_.at<float>(yi + 1, xi) + fx * edgeDist_.at<float>(yi + 1, xi + 1));
    return std::min(d, kTruncPx);
  };
  const std::size_t nd = directions.size();
  auto pose = [&](const Eigen::VectorXd& a) {
    Eigen::Matrix<double, 6, 1> m = Eigen::Matrix<double, 6, 1>::Zero();
    for (std::size_t i = 0; i < nd; ++i) m += a[static_cast<Eigen::Index>(i)] * directions[i];
    const Eigen::Vector3d c = (start * modelCentroid.homogeneous()).head<3>();
    const Eigen::Vector3d rv = m.head<3>() / radiusMm;
    Eigen::Matrix4d d = Eigen::Matrix4d::Identity();
    if (rv.norm() > 0) {
      const Eigen::Matrix3d rot = Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
      d.topLeftCorner<3, 3>() = rot;
      d.topRightCorner<3, 1>() = c - rot * c;
    }
    d.topRightCorner<3, 1>() += m.tail<3>();
    return Eigen::Matrix4d(d * start);
  };
  auto residuals = [&](const Eigen::Matrix4d& t) {
    Eigen::VectorXd r(static_cast<Eigen::Index>(rim.size()));
    const Eigen::Matrix3d rr = t.topLeftCorner<3, 3>();
    const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
    for (std::size_t j = 0; j < rim.size(); ++j) {
      const Eigen::Vector3d p = rr * points_[rim[j]] + tr;
      r[static_cast<Eigen::Index>(j)] = dist(k.fx * p.x() / p.z() + k.cx, k.fy * p.y() / p.z() + k.cy) / edgeSigmaPx;
    }
    return r;
  };
  Eigen::VectorXd a = Eigen::VectorXd::Zero(static_cast<Eigen::Index>(nd));
  auto total = [&](const Eigen::VectorXd& x, const Eigen::VectorXd& r) {
    double e = r.squaredNorm();
    for (std::size_t i = 0; i < nd; ++i) e += (i < stiffness.size() ? stiffness[i] : 0.0) * x[static_cast<Eigen::Index>(i)] * x[static_cast<Eigen::Index>(i)];
    return e;
  };
  Eigen::VectorXd r = residuals(pose(a));
  double e = total(a, r);
  const double hStep = 0.05;  // mm along a direction, numeric derivative
  for (int it = 0; it < 15; ++it) {
    Eigen::MatrixXd jac(r.size(), static_cast<Eigen::Index>(nd));
    for (std::size_t i = 0; i < nd; ++i) {
      Eigen::VectorXd ap = a, am = a;
      ap[static_cast<Eigen::Index>(i)] += hStep;
      am[static_cast<Eigen::Index>(i)] -= hStep;
      jac.col(static_cast<Eigen::Index>(i)) = (residuals(pose(ap)) - residuals(pose(am))) / (2 * hStep);
    }
    Eigen::MatrixXd hm = jac.transpose() * jac;
    Eigen::VectorXd g = jac.transpose() * r;
    for (std::size_t i = 0; i < nd; ++i) {
      const double s = i < stiffness.size() ? stiffness[i] : 0.0;
      hm(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(i)) += s + 1e-6;
      g[static_cast<Eigen::Index>(i)] += s * a[static_cast<Eigen::Index>(i)];
    }
    Eigen::VectorXd step = hm.ldlt().solve(-g);
    if (!step.allFinite()) break;
    if (step.norm() > 1.0) step *= 1.0 / step.norm();  // at most 1 mm per iteration
    bool took = false;
    for (int half = 0; half < 5 && !took; ++half, step *= 0.5) {
      const Eigen::VectorXd a2 = a + step;
      const Eigen::VectorXd r2 = residuals(pose(a2));
      const double e2 = total(a2, r2);
      if (e2 < e) {
        a = a2, r = r2, e = e2;
        took = true;
      }
    }
    if (!took || step.norm() < 1e-3) break;
  }
  return pose(a);
}

void VisibilityCheck::claim(const Eigen::Matrix4d& t, const cv::Mat& depth, const DepthIntrinsics& k, double tol,
                            double maxAngleDeg, cv::Mat& claimed) {
  if (claimed.rows != depth.rows || claimed.cols != depth.cols) claimed = cv::Mat::zeros(depth.size(), CV_8UC1);
  const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
  const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
  const double cosMin = std::cos(maxAngleDeg * M_PI / 180.0);
  for (std::size_t i = 0; i < points_.size(); ++i) {
    const Eigen::Vector3d p = r * points_[i] + tr;
    if (p.z() <= 1 || -(r * normals_[i]).dot(p) < cosMin * p.norm()) continue;
    const int ui = static_cast<int>(std::lround(k.fx * p.x() / p.z() + k.cx)), vi = static_cast<int>(std::lround(k.fy * p.y() / p.z() + k.cy));
    const int rad = std::max(1, static_cast<int>(std::lround(0.6 * spacingMm_ * k.fx / p.z())));
    for (int y = std::max(0, vi - rad); y <= std::min(depth.rows - 1, vi + rad); ++y)
      for (int x = std::max(0, ui - rad); x <= std::min(depth.cols - 1, ui + rad); ++x) {
        const float d = depth.at<float>(y, x);
        if (d > 0 && std::abs(d - p.z()) <= tol) claimed.at<std::uint8_t>(y, x) = kPixelClaimed;
      }
  }
}

std::vector<std::size_t> visibleFrom(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                                     const Eigen::Vector3d& d, double cell, double maxAngleDeg) {
  const Eigen::Vector3d a = d.unitOrthogonal(), b = d.cross(a);
  const double cosMin = std::cos(maxAngleDeg * M_PI / 180.0);
  std::map<std::pair<long, long>, double> nearest;
  auto key = [&](const Eigen::Vector3d& p) {
    return std::make_pair(static_cast<long>(std::floor(p.dot(a) / cell)), static_cast<long>(std::floor(p.dot(b) / cell)));
  };
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (-normals[i].dot(d) < cosMin) continue;
    const auto k = key(points[i]);
    const double z = points[i].dot(d);
    auto it = nearest.find(k);
    if (it == nearest.end() || z < it->second) nearest[k] = z;
  }
  std::vector<std::size_t> out;
  for (std::size_t i = 0; i < points.size(); ++i) {
    if (-normals[i].dot(d) < cosMin) continue;
    const auto k = key(points[i]);
    const double z = points[i].dot(d);
    bool hidden = false;
    for (long da = -1; da <= 1 && !hidden; ++da)
      for (long db = -1; db <= 1 && !hidden; ++db) {
        auto it = nearest.find({k.first + da, k.second + db});
        hidden = it != nearest.end() && it->second < z - 2 * cell;
      }
    if (!hidden) out.push_back(i);
  }
  return out;
}

double rotationErrorDeg(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  const Eigen::Quaterniond q(Eigen::Matrix3d(a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>()));
  return 2 * std::atan2(q.vec().norm(), std::abs(q.w())) * 180.0 / M_PI;
}

double translationErrorMm(const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
  return (a.topRightCorner<3, 1>() - b.topRightCorner<3, 1>()).norm();
}

}  // namespace vgr::vision::cloud
