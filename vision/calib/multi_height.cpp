#include "vision/calib/multi_height.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <Eigen/Dense>
#include <fmt/core.h>

namespace vgr::vision::calib {

PixelPoint PrincipalCurve::at(double h) const {
  const std::size_t n = knotH.size();
  if (n == 1) return knotUv[0];
  std::size_t j = 0;  // segment [j, j+1]
  while (j + 2 < n && h > knotH[j + 1]) ++j;
  const double f = (h - knotH[j]) / (knotH[j + 1] - knotH[j]);
  return {knotUv[j].u + f * (knotUv[j + 1].u - knotUv[j].u), knotUv[j].v + f * (knotUv[j + 1].v - knotUv[j].v)};
}

PrincipalCurve fitKSegmentCurve(const std::vector<double>& samplesH, const std::vector<PixelPoint>& samplesUv,
                                int maxSegments) {
  const std::size_t m = samplesH.size();
  std::vector<std::size_t> order(m);
  std::iota(order.begin(), order.end(), 0);
  std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return samplesH[a] < samplesH[b]; });
  const int kMax = maxSegments > 0 ? maxSegments : std::max(1, static_cast<int>(std::ceil(std::cbrt(static_cast<double>(m)) - 1e-9)));
  PrincipalCurve c;
  c.knotH = {samplesH[order.front()], samplesH[order.back()]};
  auto fit = [&]() {
    // Least squares on hat functions: (u, v)(h) = sum_j w_j(h) knotUv_j (eq. 3 with the
    // projection index fixed to the sample's height).
    const std::size_t k = c.knotH.size();
    Eigen::MatrixXd a = Eigen::MatrixXd::Zero(static_cast<Eigen::Index>(m), static_cast<Eigen::Index>(k));
    Eigen::MatrixXd b(static_cast<Eigen::Index>(m), 2);
    for (std::size_t i = 0; i < m; ++i) {
      const double h = samplesH[i];
      std::size_t j = 0;
      while (j + 2 < k && h > c.knotH[j + 1]) ++j;
      const double f = (h - c.knotH[j]) / (c.knotH[j + 1] - c.knotH[j]);
      a(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j)) = 1 - f;
      a(static_cast<Eigen::Index>(i), static_cast<Eigen::Index>(j + 1)) = f;
      b(static_cast<Eigen::Index>(i), 0) = samplesUv[i].u;
      b(static_cast<Eigen::Index>(i), 1) = samplesUv[i].v;
    }
    const Eigen::MatrixXd x = a.colPivHouseholderQr().solve(b);
    c.knotUv.resize(k);
    for (std::size_t j = 0; j < k; ++j) c.knotUv[j] = {x(static_cast<Eigen::Index>(j), 0), x(static_cast<Eigen::Index>(j), 1)};
  };
  fit();
  while (static_cast<int>(c.knotH.size()) - 1 < kMax) {
    // The segment holding the most samples gets a new vertex at its middle (paper 001).
    std::size_t best = 0;
    int bestCount = -1;
    for (std::size_t j = 0; j + 1 < c.knotH.size(); ++j) {
      int cnt = 0;
      for (double h : samplesH) cnt += (h >= c.knotH[j] && h <= c.knotH[j + 1]);
      if (cnt > bestCount) best = j, bestCount = cnt;
    }
    if (bestCount < 3) break;  // a segment with fewer samples cannot take another vertex
    c.knotH.insert(c.knotH.begin() + static_cast<long>(best) + 1, 0.5 * (c.knotH[best] + c.knotH[best + 1]));
    fit();
  }
  return c;
}

Result<MultiHeightMap> MultiHeightMap::build(int rows, int cols, const std::vector<Vec3>& gridBase, Vec3 up,
                                             const std::vector<double>& heights,
                                             const std::vector<std::vector<PixelPoint>>& image, int maxSegments) {
  const std::size_t n = static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols);
  if (rows < 2 || cols < 2) return fail(Status::BadArgument, "multi-height: the grid needs at least 2 x 2 points");
  if (gridBase.size() != n)
    return fail(Status::BadArgument, fmt::format("multi-height: {} grid points for a {} x {} grid", gridBase.size(), rows, cols));
  if (heights.size() < 2 || heights.size() != image.size())
    return fail(Status::BadArgument, fmt::format("multi-height: {} heights and {} image grids (at least 2, equal counts)",
                                                 heights.size(), image.size()));
  for (std::size_t k = 0; k < image.size(); ++k)
    if (image[k].size() != n)
      return fail(Status::BadArgument, fmt::format("multi-height: plane {} (h = {} mm) has {} image points, expected {}",
                                                   k, heights[k], image[k].size(), n));
  MultiHeightMap m;
  m.rows_ = rows;
  m.cols_ = cols;
  m.grid_ = gridBase;
  const double len = std::sqrt(up.x * up.x + up.y * up.y + up.z * up.z);
  m.up_ = {up.x / len, up.y / len, up.z / len};
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<PixelPoint> uv;
    for (const auto& plane : image) uv.push_back(plane[i]);
    m.curves_.push_back(fitKSegmentCurve(heights, uv, maxSegments));
  }
  m.segments_ = static_cast<int>(m.curves_.front().knotH.size()) - 1;
  return m;
}

std::optional<Vec3> MultiHeightMap::pixelToRobot(PixelPoint p, double h) const {
  std::vector<PixelPoint> g(curves_.size());
  for (std::size_t i = 0; i < curves_.size(); ++i) g[i] = curves_[i].at(h);
  auto idx = [&](int r, int c) { return static_cast<std::size_t>(r * cols_ + c); };
  for (int r = 0; r + 1 < rows_; ++r)
    for (int c = 0; c + 1 < cols_; ++c) {
      const Eigen::Vector2d p00(g[idx(r, c)].u, g[idx(r, c)].v), p10(g[idx(r, c + 1)].u, g[idx(r, c + 1)].v),
          p01(g[idx(r + 1, c)].u, g[idx(r + 1, c)].v), p11(g[idx(r + 1, c + 1)].u, g[idx(r + 1, c + 1)].v);
      const Eigen::Vector2d q(p.u, p.v);
      const Eigen::Vector2d lo = p00.cwiseMin(p10).cwiseMin(p01).cwiseMin(p11);
      const Eigen::Vector2d hi = p00.cwiseMax(p10).cwiseMax(p01).cwiseMax(p11);
      if ((q.array() < lo.array() - 1e-9).any() || (q.array() > hi.array() + 1e-9).any()) continue;
      // Inverse bilinear interpolation by Newton's method from the cell centre.
      double s = 0.5, t = 0.5;
      for (int it = 0; it < 20; ++it) {
        const Eigen::Vector2d f = (1 - s) * (1 - t) * p00 + s * (1 - t) * p10 + (1 - s) * t * p01 + s * t * p11 - q;
        Eigen::Matrix2d j;
        j.col(0) = (1 - t) * (p10 - p00) + t * (p11 - p01);
        j.col(1) = (1 - s) * (p01 - p00) + s * (p11 - p10);
        const Eigen::Vector2d d = j.partialPivLu().solve(f);
        s -= d(0);
        t -= d(1);
        if (d.norm() < 1e-12) break;
      }
      if (s < -1e-7 || s > 1 + 1e-7 || t < -1e-7 || t > 1 + 1e-7) continue;
      auto lerp3 = [&](const Vec3& a, const Vec3& b, const Vec3& cc, const Vec3& d, char axis) {
        auto get = [axis](const Vec3& v) { return axis == 'x' ? v.x : axis == 'y' ? v.y : v.z; };
        return (1 - s) * (1 - t) * get(a) + s * (1 - t) * get(b) + (1 - s) * t * get(cc) + s * t * get(d);
      };
      const Vec3 &w00 = grid_[idx(r, c)], &w10 = grid_[idx(r, c + 1)], &w01 = grid_[idx(r + 1, c)],
                 &w11 = grid_[idx(r + 1, c + 1)];
      return Vec3{lerp3(w00, w10, w01, w11, 'x') + h * up_.x, lerp3(w00, w10, w01, w11, 'y') + h * up_.y,
                  lerp3(w00, w10, w01, w11, 'z') + h * up_.z};
    }
  return std::nullopt;
}

}  // namespace vgr::vision::calib
