#include "sim/depth_render.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <random>

#include <Eigen/Geometry>

namespace vgr::sim {
namespace {

using V3 = Eigen::Vector3d;

constexpr double kNearMm = 1;  // triangles are clipped at z = 1 mm

void drawTriangle(const V3& a, const V3& b, const V3& c, std::uint16_t label, const DepthCameraModel& cam, ExactDepth& out);

}  // namespace

void rasterize(const std::vector<MeshInstance>& meshes, const DepthCameraModel& cam, ExactDepth& out) {
  out.z.create(cam.height, cam.width, CV_64FC1);
  out.z.setTo(std::numeric_limits<double>::infinity());
  out.cosine.create(cam.height, cam.width, CV_32FC1);
  out.cosine.setTo(0);
  out.labels.create(cam.height, cam.width, CV_16UC1);
  out.labels.setTo(0);
  for (const auto& inst : meshes) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(inst.pose.qw, inst.pose.qx, inst.pose.qy, inst.pose.qz).normalized();
    const V3 t(inst.pose.x, inst.pose.y, inst.pose.z);
    std::vector<V3> v;
    v.reserve(inst.mesh->vertices.size());
    for (const auto& p : inst.mesh->vertices) v.push_back(q * V3(p[0], p[1], p[2]) + t);
    for (const auto& tri : inst.mesh->triangles) {
      const V3& a0 = v[static_cast<std::size_t>(tri[0])];
      const V3& b0 = v[static_cast<std::size_t>(tri[1])];
      const V3& c0 = v[static_cast<std::size_t>(tri[2])];
      if (a0.z() >= kNearMm && b0.z() >= kNearMm && c0.z() >= kNearMm) {
        drawTriangle(a0, b0, c0, inst.label, cam, out);
        continue;
      }
      // Clip against the near plane z = kNearMm (Sutherland-Hodgman), then fan.
      const V3 in[3] = {a0, b0, c0};
      V3 poly[4];
      int n = 0;
      for (int i = 0; i < 3; ++i) {
        const V3& p = in[i];
        const V3& e = in[(i + 1) % 3];
        const bool pin = p.z() >= kNearMm, qin = e.z() >= kNearMm;
        if (pin) poly[n++] = p;
        if (pin != qin) poly[n++] = p + (e - p) * ((kNearMm - p.z()) / (e.z() - p.z()));
      }
      for (int i = 1; i + 1 < n; ++i) drawTriangle(poly[0], poly[i], poly[i + 1], inst.label, cam, out);
    }
  }
}

namespace {

void drawTriangle(const V3& a, const V3& b, const V3& c, std::uint16_t label, const DepthCameraModel& cam, ExactDepth& out) {
  // Projections: straight edges stay straight under a pinhole, so the pixel-centre
  // inside test on the projected triangle is exact.
  const double ua = cam.fx * a.x() / a.z() + cam.cx, va = cam.fy * a.y() / a.z() + cam.cy;
  const double ub = cam.fx * b.x() / b.z() + cam.cx, vb = cam.fy * b.y() / b.z() + cam.cy;
  const double uc = cam.fx * c.x() / c.z() + cam.cx, vc = cam.fy * c.y() / c.z() + cam.cy;
  const double area = (ub - ua) * (vc - va) - (vb - va) * (uc - ua);
  if (std::abs(area) < 1e-12) return;  // seen edge-on
  const int u0 = std::max(0, static_cast<int>(std::ceil(std::min({ua, ub, uc}))));
  const int u1 = std::min(cam.width - 1, static_cast<int>(std::floor(std::max({ua, ub, uc}))));
  const int v0 = std::max(0, static_cast<int>(std::ceil(std::min({va, vb, vc}))));
  const int v1 = std::min(cam.height - 1, static_cast<int>(std::floor(std::max({va, vb, vc}))));
  if (u0 > u1 || v0 > v1) return;
  const V3 n = (b - a).cross(c - a);
  const double nDotA = n.dot(a);
  const double nNorm = n.norm();
  const double s = area > 0 ? 1.0 : -1.0;
  for (int y = v0; y <= v1; ++y) {
    double* zr = out.z.ptr<double>(y);
    float* cr = out.cosine.ptr<float>(y);
    std::uint16_t* lr = out.labels.ptr<std::uint16_t>(y);
    for (int x = u0; x <= u1; ++x) {
      const double e0 = s * ((ub - ua) * (y - va) - (vb - va) * (x - ua));
      const double e1 = s * ((uc - ub) * (y - vb) - (vc - vb) * (x - ub));
      const double e2 = s * ((ua - uc) * (y - vc) - (va - vc) * (x - uc));
      if (e0 < 0 || e1 < 0 || e2 < 0) continue;
      // The pixel's ray r = ((x - cx) / fx, (y - cy) / fy, 1) meets the plane n.X = n.a at
      // X = r * (n.a / n.r): its z is that factor, exactly.
      const V3 r((x - cam.cx) / cam.fx, (y - cam.cy) / cam.fy, 1.0);
      const double nr = n.dot(r);
      if (std::abs(nr) < 1e-15) continue;
      const double z = nDotA / nr;
      if (z <= 0 || z >= zr[x]) continue;
      zr[x] = z;
      cr[x] = static_cast<float>(std::abs(nr) / (nNorm * r.norm()));
      lr[x] = label;
    }
  }
}

}  // namespace

cv::Mat applySensor(const ExactDepth& exact, const DepthCameraModel& cam, const DepthSensorOptions& sensor, std::uint64_t seed) {
  const int w = cam.width, h = cam.height;
  cv::Mat out(h, w, CV_16UC1, cv::Scalar(0));
  const double cosMin = std::cos(sensor.grazingDeg * M_PI / 180.0);
  std::mt19937_64 rng(seed * 0x9E3779B97F4A7C15ull + 0x2545F4914F6CDD1Dull);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::uniform_real_distribution<double> uni(0.0, 1.0);
  for (int y = 0; y < h; ++y) {
    const double* zr = exact.z.ptr<double>(y);
    const float* cr = exact.cosine.ptr<float>(y);
    std::uint16_t* o = out.ptr<std::uint16_t>(y);
    for (int x = 0; x < w; ++x) {
      // Draw both numbers for every pixel, so one pixel's fate never shifts another's noise.
      const double g = gauss(rng), u = uni(rng);
      const double z = zr[x];
      if (!std::isfinite(z) || cr[x] < cosMin) continue;  // nothing there, or grazing
      bool jump = false;  // mixed pixels at a depth edge
      for (int dy = -1; dy <= 1 && !jump; ++dy)
        for (int dx = -1; dx <= 1 && !jump; ++dx) {
          const int yy = y + dy, xx = x + dx;
          if (yy < 0 || yy >= h || xx < 0 || xx >= w) continue;
          const double zn = exact.z.at<double>(yy, xx);
          jump = !std::isfinite(zn) || std::abs(zn - z) > sensor.jumpMm;
        }
      if (jump || u < sensor.dropout) continue;
      const double sigma = sensor.noiseMmAt500 * (z / 500.0) * (z / 500.0);
      const double v = std::round((z + sigma * g) / cam.depthScaleMm);
      if (v >= 1 && v <= 65535) o[x] = static_cast<std::uint16_t>(v);
    }
  }
  return out;
}

cv::Mat depthToMm(const cv::Mat& depth16, double depthScaleMm) {
  cv::Mat out;
  depth16.convertTo(out, CV_32FC1, depthScaleMm);
  return out;
}

}  // namespace vgr::sim
