#include "sim/depth_calib_scene.hpp"

#include <cmath>
#include <limits>

#include <Eigen/Geometry>

#include "vision/calib/se3.hpp"

namespace vgr::sim {

namespace se3 = vision::se3;

DepthCamera defaultDepthCamera() { return DepthCamera{}; }

vision::calib::SphereTarget defaultSphereTarget() {
  vision::calib::SphereTarget t;
  t.radiusMm = 12.5;
  // Target frame: the plate in z = 0, the camera side at negative z (as the plates of
  // calib_scene.hpp: z into the board).
  t.centres = {{10, 15, -25}, {140, 10, -40}, {75, 60, -55}, {20, 110, -35}, {130, 105, -20}};
  return t;
}

vision::calib::PatternSpec sphereTargetFootprint() {
  vision::calib::PatternSpec s;
  s.kind = vision::calib::PatternKind::Chessboard;
  s.cols = 6;
  s.rows = 5;
  s.pitchMm = 30;
  return s;
}

cv::Mat renderSphereTargetDepth(const DepthCamera& camera, const vision::calib::SphereTarget& target,
                                const vision::calib::PatternSpec& footprint, const Pose& camFromTarget,
                                const DepthRenderOptions& options) {
  const se3::Iso t = se3::toIso(camFromTarget);
  std::vector<Eigen::Vector3d> centres;
  for (const auto& c : target.centres) centres.push_back(t * Eigen::Vector3d(c.x, c.y, c.z));
  const double r2 = target.radiusMm * target.radiusMm;
  const Eigen::Vector3d planeNormal = t.linear().col(2), planePoint = t.translation();
  const se3::Iso inv = t.inverse();
  const double lo = -footprint.pitchMm, hiX = footprint.cols * footprint.pitchMm, hiY = footprint.rows * footprint.pitchMm;
  const auto& k = camera.intrinsics;
  cv::Mat depth(camera.height, camera.width, CV_32FC1, cv::Scalar(0));
  cv::Mat noise(camera.height, camera.width, CV_32FC1);
  cv::RNG rng(options.seed * 0x9E3779B97F4A7C15ull + 3);
  rng.fill(noise, cv::RNG::NORMAL, 0.0, options.noiseSigmaMm);
  for (int v = 0; v < camera.height; ++v) {
    float* row = depth.ptr<float>(v);
    const float* nrow = noise.ptr<float>(v);
    for (int u = 0; u < camera.width; ++u) {
      // The ray p(s) = s d with d.z = 1: s is the z-depth of the hit.
      const Eigen::Vector3d d((u - k.cx) / k.fx, (v - k.cy) / k.fy, 1.0);
      double best = std::numeric_limits<double>::infinity();
      const double dd = d.squaredNorm();
      for (const auto& c : centres) {
        const double b = d.dot(c), disc = b * b - dd * (c.squaredNorm() - r2);
        if (disc < 0) continue;
        const double s = (b - std::sqrt(disc)) / dd;
        if (s > 0 && s < best) best = s;
      }
      if (options.plate) {
        const double den = planeNormal.dot(d);
        if (std::abs(den) > 1e-12) {
          const double s = planeNormal.dot(planePoint) / den;
          if (s > 0 && s < best) {
            const Eigen::Vector3d q = inv * (s * d);
            if (q.x() >= lo && q.x() <= hiX && q.y() >= lo && q.y() <= hiY) best = s;
          }
        }
      }
      if (std::isfinite(best)) row[u] = static_cast<float>(best + nrow[u]);
    }
  }
  return depth;
}

cv::Mat quantiseDepth(const cv::Mat& depthMm, double depthScaleMm) {
  cv::Mat out(depthMm.size(), CV_16UC1, cv::Scalar(0));
  for (int v = 0; v < depthMm.rows; ++v) {
    const float* in = depthMm.ptr<float>(v);
    auto* o = out.ptr<std::uint16_t>(v);
    for (int u = 0; u < depthMm.cols; ++u) {
      const double units = std::round(in[u] / depthScaleMm);
      o[u] = in[u] > 0 && units <= 65535.0 ? static_cast<std::uint16_t>(units) : 0;
    }
  }
  return out;
}

}  // namespace vgr::sim
