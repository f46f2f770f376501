#include "vision/grasp/height_map.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Eigenvalues>
#include <fmt/core.h>

namespace vgr::vision::grasp {
namespace {

struct Hypothesis {
  Eigen::Vector3d n = -Eigen::Vector3d::UnitZ();
  double offset = 0;
};

// The plane n . p = offset through three points; false when they are (nearly) collinear.
bool planeThrough(const Eigen::Vector3d& a, const Eigen::Vector3d& b, const Eigen::Vector3d& c, Hypothesis& h) {
  Eigen::Vector3d n = (b - a).cross(c - a);
  const double len = n.norm();
  if (len < 1e-6 * (b - a).norm() * (c - a).norm() || len == 0) return false;
  n /= len;
  if (n.z() > 0) n = -n;  // toward the camera
  h.n = n;
  h.offset = n.dot(a);
  return true;
}

}  // namespace

cv::Point3d backProject(const DepthIntrinsics& c, double u, double v, double z) {
  return {(u - c.cx) / c.fx * z, (v - c.cy) / c.fy * z, z};
}

Result<FloorPlane> fitFloorPlane(const cv::Mat& z, const DepthIntrinsics& cam, const std::string& name, const FloorOptions& o) {
  if (z.type() != CV_32FC1 || z.cols != cam.width || z.rows != cam.height)
    return fail(Status::BadArgument, fmt::format("{}: expected a {}x{} depth image in mm (CV_32FC1), got {}x{} of type {}", name,
                                                 cam.width, cam.height, z.cols, z.rows, z.type()));
  if (o.gridStepPx < 1 || o.gridStepPx > 64 || o.iterations < 10 || o.iterations > 100000 || !(o.inlierMm > 0) ||
      o.inlierMm > 100 || !(o.minInlierShare > 0) || o.minInlierShare > 1)
    return fail(Status::BadArgument, fmt::format("{}: floor fit options out of range", name));
  std::vector<Eigen::Vector3d> pts;
  for (int v = 0; v < z.rows; v += o.gridStepPx)
    for (int u = 0; u < z.cols; u += o.gridStepPx) {
      const float d = z.at<float>(v, u);
      if (d > 0 && std::isfinite(d)) {
        const auto p = backProject(cam, u, v, d);
        pts.emplace_back(p.x, p.y, p.z);
      }
    }
  if (pts.size() < 50) return fail(Status::BadArgument, fmt::format("{}: too few valid depth pixels ({}) to find the floor", name, pts.size()));

  // RANSAC (fixed seed: the same image always gives the same plane).
  std::mt19937 rng(12345);
  std::uniform_int_distribution<std::size_t> pick(0, pts.size() - 1);
  Hypothesis best;
  std::size_t bestCount = 0;
  for (int it = 0; it < o.iterations; ++it) {
    Hypothesis h;
    if (!planeThrough(pts[pick(rng)], pts[pick(rng)], pts[pick(rng)], h)) continue;
    std::size_t count = 0;
    for (const auto& p : pts) count += std::abs(h.n.dot(p) - h.offset) <= o.inlierMm;
    if (count > bestCount) bestCount = count, best = h;
  }
  const double share = static_cast<double>(bestCount) / static_cast<double>(pts.size());
  if (bestCount < 3 || share < o.minInlierShare)
    return fail(Status::BadArgument, fmt::format("{}: no floor plane: the largest plane holds {:.0f} % of the valid pixels, expected >= {:.0f} %",
                                                 name, 100 * share, 100 * o.minInlierShare));

  // Least-squares refit on the inliers: the normal is the smallest principal axis.
  Eigen::Vector3d mean = Eigen::Vector3d::Zero();
  std::size_t n = 0;
  for (const auto& p : pts)
    if (std::abs(best.n.dot(p) - best.offset) <= o.inlierMm) mean += p, ++n;
  mean /= static_cast<double>(n);
  Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
  for (const auto& p : pts)
    if (std::abs(best.n.dot(p) - best.offset) <= o.inlierMm) cov += (p - mean) * (p - mean).transpose();
  Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
  Eigen::Vector3d normal = eig.eigenvectors().col(0);
  if (normal.z() > 0) normal = -normal;
  if (normal.z() > -0.2)
    return fail(Status::BadArgument, fmt::format("{}: the largest plane is seen almost edge-on (normal z {:.2f}): not a floor", name, normal.z()));
  FloorPlane f;
  f.nx = normal.x(), f.ny = normal.y(), f.nz = normal.z();
  f.offset = normal.dot(mean);
  double ss = 0;
  for (const auto& p : pts)
    if (std::abs(best.n.dot(p) - best.offset) <= o.inlierMm) ss += std::pow(normal.dot(p) - f.offset, 2);
  f.rmsMm = std::sqrt(ss / static_cast<double>(n));
  f.inlierShare = share;
  return f;
}

cv::Mat heightAboveFloor(const cv::Mat& z, const DepthIntrinsics& c, const FloorPlane& f) {
  cv::Mat h(z.size(), CV_32FC1);
  const double nan = std::numeric_limits<double>::quiet_NaN();
  for (int v = 0; v < z.rows; ++v) {
    const float* zr = z.ptr<float>(v);
    float* hr = h.ptr<float>(v);
    const double ry = (v - c.cy) / c.fy;
    for (int u = 0; u < z.cols; ++u) {
      const double d = zr[u];
      // n . p - offset with p = d * ((u - cx) / fx, (v - cy) / fy, 1)
      hr[u] = static_cast<float>(d > 0 && std::isfinite(d) ? d * (f.nx * (u - c.cx) / c.fx + f.ny * ry + f.nz) - f.offset : nan);
    }
  }
  return h;
}

cv::Mat hasData(const cv::Mat& h) {
  cv::Mat m(h.size(), CV_8UC1);
  for (int v = 0; v < h.rows; ++v) {
    const float* hr = h.ptr<float>(v);
    std::uint8_t* mr = m.ptr<std::uint8_t>(v);
    for (int u = 0; u < h.cols; ++u) mr[u] = std::isnan(hr[u]) ? 0 : 255;
  }
  return m;
}

int fillHolesLow(cv::Mat& h, int passes) {
  cv::Mat next;
  int left = 0;
  for (int pass = 0; pass < passes; ++pass) {
    h.copyTo(next);
    left = 0;
    bool filled = false;
    for (int y = 0; y < h.rows; ++y)
      for (int x = 0; x < h.cols; ++x) {
        if (!std::isnan(h.at<float>(y, x))) continue;
        float lowest = std::numeric_limits<float>::quiet_NaN();
        for (int dy = -1; dy <= 1; ++dy)
          for (int dx = -1; dx <= 1; ++dx) {
            const int yy = y + dy, xx = x + dx;
            if (yy < 0 || xx < 0 || yy >= h.rows || xx >= h.cols) continue;
            const float n = h.at<float>(yy, xx);
            if (!std::isnan(n) && !(n >= lowest)) lowest = n;
          }
        next.at<float>(y, x) = lowest;
        filled = filled || !std::isnan(lowest);
        left += std::isnan(lowest);
      }
    std::swap(h, next);
    if (!filled) break;
  }
  if (passes <= 0) left = cv::countNonZero(~hasData(h));
  return left;
}

double depthNear(const cv::Mat& z, double u, double v, int r) {
  const int ui = static_cast<int>(std::lround(u)), vi = static_cast<int>(std::lround(v));
  std::vector<float> vals;
  for (int y = std::max(0, vi - r); y <= std::min(z.rows - 1, vi + r); ++y)
    for (int x = std::max(0, ui - r); x <= std::min(z.cols - 1, ui + r); ++x) {
      const float d = z.at<float>(y, x);
      if (d > 0 && std::isfinite(d)) vals.push_back(d);
    }
  if (vals.empty()) return 0;
  std::nth_element(vals.begin(), vals.begin() + static_cast<long>(vals.size() / 2), vals.end());
  return vals[vals.size() / 2];
}

}  // namespace vgr::vision::grasp
