// The depth renderer (sim/depth_render.hpp, sim/depth_scene.hpp): an exact pinhole z-buffer,
// the sensor model (noise ~ z^2, dropout, grazing and jump invalidation, quantisation), the
// parts' geometry and the scenes' truth.
#include <cmath>
#include <numeric>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "sim/depth_parts.hpp"
#include "sim/depth_render.hpp"
#include "sim/depth_scene.hpp"

namespace {

using namespace vgr::sim;
using V3 = Eigen::Vector3d;

TriMesh quadMesh(double half) {  // a square in the z = 0 plane of its own frame
  TriMesh m;
  m.vertices = {{-half, -half, 0}, {half, -half, 0}, {half, half, 0}, {-half, half, 0}};
  m.triangles = {{0, 1, 2}, {0, 2, 3}};
  return m;
}

vgr::Pose poseOf(const Eigen::Isometry3d& t) {
  const Eigen::Quaterniond q(t.linear());
  return {t.translation().x(), t.translation().y(), t.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

DepthSensorOptions noiseless() {
  DepthSensorOptions s;
  s.noiseMmAt500 = 0;
  s.dropout = 0;
  return s;
}

TEST(depth_render, ZOfATiltedPlaneIsExactAtEveryPixelCentre) {
  const TriMesh plane = quadMesh(2000);
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(0.5, V3(1, 2, 0).normalized()).toRotationMatrix();
  t.translation() = V3(10, -20, 700);
  DepthCameraModel cam;
  ExactDepth e;
  rasterize({{&plane, poseOf(t), 7}}, cam, e);
  const V3 n = t.linear() * V3::UnitZ();
  const double d = n.dot(t.translation());
  double worst = 0;
  for (int v = 0; v < cam.height; v += 7)
    for (int u = 0; u < cam.width; u += 5) {
      const V3 r((u - cam.cx) / cam.fx, (v - cam.cy) / cam.fy, 1);
      worst = std::max(worst, std::abs(e.z.at<double>(v, u) - d / n.dot(r)));
      ASSERT_EQ(e.labels.at<std::uint16_t>(v, u), 7);
    }
  EXPECT_LT(worst, 1e-9);
}

TEST(depth_render, NoiseGrowsWithTheSquareOfZ) {
  const TriMesh plane = quadMesh(4000);
  DepthCameraModel cam;
  cam.depthScaleMm = 0.02;  // quantisation (0.006 mm rms) far below the noise
  DepthSensorOptions s = noiseless();
  s.noiseMmAt500 = 0.3;
  double sigma[2];
  const double z[2] = {500, 1000};
  for (int k = 0; k < 2; ++k) {
    Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
    t.translation() = V3(0, 0, z[k]);
    ExactDepth e;
    rasterize({{&plane, poseOf(t), 1}}, cam, e);
    const cv::Mat mm = depthToMm(applySensor(e, cam, s, 5), cam.depthScaleMm);
    cv::Scalar mean, sd;
    cv::meanStdDev(mm, mean, sd);
    EXPECT_NEAR(mean[0], z[k], 0.01);
    sigma[k] = sd[0];
  }
  EXPECT_NEAR(sigma[0], 0.3, 0.01);
  EXPECT_NEAR(sigma[1], 1.2, 0.03);  // (1000 / 500)^2 = 4 times
}

TEST(depth_render, DropoutQuantisationAndGrazing) {
  const TriMesh plane = quadMesh(4000);
  DepthCameraModel cam;
  DepthSensorOptions s = noiseless();
  s.dropout = 0.01;
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.translation() = V3(0, 0, 500.04);
  ExactDepth e;
  rasterize({{&plane, poseOf(t), 1}}, cam, e);
  const cv::Mat d = applySensor(e, cam, s, 9);
  const double zeros = 1.0 - cv::countNonZero(d) / double(d.total());
  EXPECT_NEAR(zeros, 0.01, 0.002);
  double minV, maxV;
  cv::minMaxLoc(d, &minV, &maxV, nullptr, nullptr, d > 0);
  EXPECT_EQ(minV, 5000);  // 500.04 mm in 0.1 mm steps, rounded
  EXPECT_EQ(maxV, 5000);

  // A plane turned 80 deg from the optical axis is seen more obliquely than 78 deg: no data;
  // turned 70 deg it is seen.
  for (double deg : {80.0, 70.0}) {
    Eigen::Isometry3d r = Eigen::Isometry3d::Identity();
    r.linear() = Eigen::AngleAxisd(deg * M_PI / 180, V3::UnitY()).toRotationMatrix();
    r.translation() = V3(0, 0, 600);
    rasterize({{&plane, poseOf(r), 1}}, cam, e);
    const cv::Mat g = applySensor(e, cam, noiseless(), 1);
    // Only the central column's rays meet the plane at exactly deg; compare there.
    const int valid = cv::countNonZero(g.col(cam.width / 2));
    if (deg > 78) EXPECT_EQ(valid, 0);
    else EXPECT_EQ(valid, cam.height);
  }
}

TEST(depth_render, PixelsAtADepthJumpHaveNoData) {
  const TriMesh floor = quadMesh(4000), top = quadMesh(50);
  DepthCameraModel cam;
  Eigen::Isometry3d f = Eigen::Isometry3d::Identity(), b = Eigen::Isometry3d::Identity();
  f.translation() = V3(0, 0, 600);
  b.translation() = V3(0, 0, 580);  // a 100 x 100 mm plate floating 20 mm above the floor
  ExactDepth e;
  rasterize({{&floor, poseOf(f), 1}, {&top, poseOf(b), 2}}, cam, e);
  const cv::Mat d = applySensor(e, cam, noiseless(), 1);
  // Row through the centre: the plate's edge at x = 50 mm lies at u = cx + 800 * 50 / 580.
  const int v = cam.height / 2;
  const double edge = cam.cx + cam.fx * 50 / 580;
  const int inner = static_cast<int>(std::floor(edge));  // the plate's last pixel; inner + 1 is floor
  for (int u = inner - 3; u <= inner + 4; ++u) {
    const bool nearEdge = u == inner || u == inner + 1;
    EXPECT_EQ(d.at<std::uint16_t>(v, u) == 0, nearEdge) << "u " << u << " edge " << edge;
  }
}

TEST(depth_parts, ThreePartsWithStableFacesAndClosedExteriors) {
  ASSERT_EQ(depthPartNames().size(), 3u);
  for (const auto& name : depthPartNames()) {
    auto p = depthPart(name);
    ASSERT_TRUE(p) << name;
    EXPECT_GE(p->stableFaces.size(), 1u) << name;
    EXPECT_EQ(p->stableFaces.front().name, "-z") << name;
    // The exterior is a closed surface: the area-weighted sum of its normals vanishes.
    const TriMesh m = exteriorMesh(*p, 2.0);
    V3 sum = V3::Zero();
    double area = 0;
    for (const auto& t : m.triangles) {
      const V3 a(m.vertices[t[0]].data()), b(m.vertices[t[1]].data()), c(m.vertices[t[2]].data());
      sum += (b - a).cross(c - a) / 2;
      area += (b - a).cross(c - a).norm() / 2;
    }
    EXPECT_LT(sum.norm(), 0.01 * area) << name;
    // Surface samples lie on the exterior, normals outward (away from the centroid on average).
    const auto pts = sampleSurface(*p, 1.0);
    EXPECT_GT(pts.size(), 3000u) << name;
    double outward = 0;
    for (const auto& s : pts) outward += (V3(s.x, s.y, s.z) - V3(p->centroid.data())).dot(V3(s.nx, s.ny, s.nz));
    EXPECT_GT(outward, 0) << name;
  }
  EXPECT_FALSE(depthPart("pipe"));
  EXPECT_EQ(depthPart("bracket")->stableFaces.size(), 4u);  // -z, +x, -x, -y
}

// Distance from p to triangle abc (Ericson, Real-Time Collision Detection, 5.1.5).
double pointTriangle(const V3& p, const V3& a, const V3& b, const V3& c) {
  const V3 ab = b - a, ac = c - a, ap = p - a;
  const double d1 = ab.dot(ap), d2 = ac.dot(ap);
  if (d1 <= 0 && d2 <= 0) return (p - a).norm();
  const V3 bp = p - b;
  const double d3 = ab.dot(bp), d4 = ac.dot(bp);
  if (d3 >= 0 && d4 <= d3) return (p - b).norm();
  const double vc = d1 * d4 - d3 * d2;
  if (vc <= 0 && d1 >= 0 && d3 <= 0) return (p - (a + ab * (d1 / (d1 - d3)))).norm();
  const V3 cp = p - c;
  const double d5 = ab.dot(cp), d6 = ac.dot(cp);
  if (d6 >= 0 && d5 <= d6) return (p - c).norm();
  const double vb = d5 * d2 - d1 * d6;
  if (vb <= 0 && d2 >= 0 && d6 <= 0) return (p - (a + ac * (d2 / (d2 - d6)))).norm();
  const double va = d3 * d6 - d5 * d4;
  if (va <= 0 && (d4 - d3) >= 0 && (d5 - d6) >= 0) return (p - (b + (c - b) * ((d4 - d3) / ((d4 - d3) + (d5 - d6))))).norm();
  const double denom = 1 / (va + vb + vc);
  return (p - (a + ab * (vb * denom) + ac * (vc * denom))).norm();
}

TEST(depth_scene, TruthPosesPutTheModelOnTheMeasuredSurface) {
  for (const auto& name : depthPartNames()) {
    DepthSceneOptions o;
    o.part = name;
    o.partsPerScene = 3;
    o.sensor = noiseless();
    o.seed = 4;
    auto scene = renderDepthScene(o, 2);
    ASSERT_TRUE(scene) << scene.error().message;
    ASSERT_GE(scene->parts.size(), 1u) << name;
    const DepthPart part = *depthPart(name);
    for (std::size_t k = 0; k < scene->parts.size(); ++k) {
      const auto& t = scene->parts[k].pose;
      EXPECT_NEAR(t.qw * t.qw + t.qx * t.qx + t.qy * t.qy + t.qz * t.qz, 1.0, 1e-12);
      EXPECT_GE(t.qw, 0);
      Eigen::Isometry3d camFromModel = Eigen::Isometry3d::Identity();
      camFromModel.linear() = Eigen::Quaterniond(t.qw, t.qx, t.qy, t.qz).toRotationMatrix();
      camFromModel.translation() = V3(t.x, t.y, t.z);
      const Eigen::Isometry3d modelFromCam = camFromModel.inverse();
      double worst = 0;
      int checked = 0;
      for (int v = 0; v < scene->depth.rows; v += 2)
        for (int u = 0; u < scene->depth.cols; u += 2) {
          if (scene->labels.at<std::uint16_t>(v, u) != k + 1) continue;
          const double z = scene->depth.at<std::uint16_t>(v, u) * o.camera.depthScaleMm;
          if (z == 0) continue;
          const V3 p = modelFromCam * V3((u - o.camera.cx) / o.camera.fx * z, (v - o.camera.cy) / o.camera.fy * z, z);
          double best = 1e9;
          for (const auto& tri : part.mesh.triangles)
            best = std::min(best, pointTriangle(p, V3(part.mesh.vertices[tri[0]].data()), V3(part.mesh.vertices[tri[1]].data()),
                                                V3(part.mesh.vertices[tri[2]].data())));
          worst = std::max(worst, best);
          ++checked;
        }
      EXPECT_GT(checked, 100) << name << " part " << k;
      EXPECT_LT(worst, 0.06) << name << " part " << k;  // the 0.1 mm quantisation: <= 0.05 mm along the ray
      EXPECT_GT(scene->parts[k].visiblePixels, 0);
      EXPECT_LE(scene->parts[k].visiblePixels, scene->parts[k].pixels);
    }
  }
}

TEST(depth_scene, OcclusionHidesTheAskedShareAndScenesAreDeterministic) {
  DepthSceneOptions o;
  o.occlusion = 0.8;
  o.clutter = 0;
  auto a = renderDepthScene(o, 11);
  ASSERT_TRUE(a);
  ASSERT_EQ(a->parts.size(), 1u);
  const double shown = a->parts[0].visiblePixels / double(a->parts[0].pixels);
  EXPECT_NEAR(shown, 0.2, 0.02);
  auto b = renderDepthScene(o, 11);
  EXPECT_EQ(cv::norm(a->depth, b->depth, cv::NORM_INF), 0);
  auto c = renderDepthScene(o, 12);
  EXPECT_GT(cv::norm(a->depth, c->depth, cv::NORM_INF), 0);

  o.emptyRatio = 1;
  auto e = renderDepthScene(o, 3);
  ASSERT_TRUE(e);
  EXPECT_TRUE(e->parts.empty());
  o.part = "pipe";
  EXPECT_FALSE(renderDepthScene(o, 3));
}

TEST(depth_scene, ViewsReportPosesWithTheAskedNoiseAndOneBadView) {
  PartViewsOptions o;
  o.badView = 5;
  auto views = renderPartViews(o);
  ASSERT_TRUE(views);
  ASSERT_EQ(views->size(), 12u);
  for (std::size_t k = 0; k < views->size(); ++k) {
    const auto& v = (*views)[k];
    const double dx = v.reported.x - v.cameraInModel.x, dy = v.reported.y - v.cameraInModel.y, dz = v.reported.z - v.cameraInModel.z;
    const Eigen::Quaterniond qt(v.cameraInModel.qw, v.cameraInModel.qx, v.cameraInModel.qy, v.cameraInModel.qz);
    const Eigen::Quaterniond qr(v.reported.qw, v.reported.qx, v.reported.qy, v.reported.qz);
    const double angleDeg = qt.angularDistance(qr) * 180 / M_PI;
    EXPECT_LE(angleDeg, 0.5 * std::sqrt(3.0) + 1e-9);
    if (k == 5) {
      EXPECT_NEAR(std::sqrt(dx * dx + dy * dy + dz * dz), 20, 1.8);
    } else {
      EXPECT_LE(std::max({std::abs(dx), std::abs(dy), std::abs(dz)}), 1.0);
    }
    EXPECT_GT(cv::countNonZero(v.depth), 1000);
  }
}

}  // namespace
