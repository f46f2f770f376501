// Work plane + pixel <-> robot mapping through a calibration made from synthetic data
// (intrinsics -> hand-eye -> plane from a plate on the conveyor), and the multi-height map of
// paper 001. Truth: sim/calib_scene's camera and hand-eye.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/calib3d.hpp>

#include "sim/calib_scene.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/multi_height.hpp"
#include "vision/calib/se3.hpp"

namespace {

using namespace vgr;
using vision::calib::PatternKind;
using vision::calib::PatternSpec;
namespace se3 = vision::se3;
namespace calib = vision::calib;

const PatternSpec kSpec{PatternKind::Chessboard, 9, 6, 20.0};

// A noise-free cell calibrated end to end like a real one: intrinsics from plate views,
// eye-to-hand hand-eye, work plane from a plate lying on the conveyor (z = 0).
struct CalibratedCell {
  sim::TrueCamera truthCam = sim::defaultCalibCamera();
  sim::HandEyeScenario truth;
  calib::CameraIntrinsics cam;
  Pose baseFromCamera;
  calib::WorkPlane plane;
};

CalibratedCell calibrateCell() {
  CalibratedCell c;
  // Intrinsics.
  std::vector<calib::ViewDetection> views;
  const auto poses = sim::randomPlateViews(c.truthCam, kSpec, 12, 21);
  for (std::size_t i = 0; i < poses.size(); ++i)
    views.push_back({"view" + std::to_string(i), true, sim::projectPattern(c.truthCam, kSpec, poses[i]), {}, {}});
  auto intr = calib::calibrateIntrinsics(views, kSpec, c.truthCam.imageSize);
  EXPECT_TRUE(intr);
  c.cam = intr->camera;
  // Hand-eye (camera fixed above the conveyor, plate in the gripper).
  c.truth = sim::makeHandEyeScenario(calib::HandEyeConfig::EyeToHand, c.truthCam, kSpec, 12, 22, 0, 0);
  std::vector<calib::HandEyeView> he;
  for (std::size_t i = 0; i < c.truth.camFromPlate.size(); ++i)
    he.push_back({"pose" + std::to_string(i), c.truth.robotReported[i],
                  sim::projectPattern(c.truthCam, kSpec, c.truth.camFromPlate[i])});
  auto hr = calib::calibrateHandEye(he, c.cam, kSpec, calib::HandEyeConfig::EyeToHand);
  EXPECT_TRUE(hr);
  c.baseFromCamera = hr->bestResult().x;
  // A plate lying on the conveyor, face up (its z axis points down into the belt).
  const se3::Iso basePlate = Eigen::Translation3d(330, -60, 0) * Eigen::AngleAxisd(0.2, Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX());
  const Pose camPlateTrue = se3::toPose(se3::toIso(c.truth.x).inverse() * basePlate);
  const auto seen = sim::projectPattern(c.truthCam, kSpec, camPlateTrue);
  cv::Vec3d rv, tv;
  cv::solvePnP(calib::patternObjectPoints(kSpec), seen, c.cam.cameraMatrix, c.cam.dist, rv, tv);
  c.plane = calib::planeFromPlate(c.baseFromCamera, se3::toPose(se3::fromRvecTvec(rv, tv)));
  return c;
}

TEST(calib_mapping, pixel_to_robot_within_0p05mm_at_the_plane_and_at_25mm) {
  const CalibratedCell c = calibrateCell();
  const calib::CameraPlaneMapping map(c.cam, c.baseFromCamera, c.plane);
  const se3::Iso baseCamTrue = se3::toIso(c.truth.x);
  std::mt19937 rng(5);
  std::uniform_real_distribution<double> ux(200, 600), uy(-200, 200);
  double worst0 = 0, worst25 = 0;
  for (double h : {0.0, 25.0}) {
    for (int i = 0; i < 200; ++i) {
      // A true point at height h above the conveyor, imaged by the true camera (with distortion).
      const Eigen::Vector3d pb(ux(rng), uy(rng), h);
      const Eigen::Vector3d pc = baseCamTrue.inverse() * pb;
      std::vector<cv::Point2d> img;
      cv::projectPoints(std::vector<cv::Point3d>{{pc.x(), pc.y(), pc.z()}}, cv::Vec3d(), cv::Vec3d(),
                        c.truthCam.cameraMatrix, c.truthCam.dist, img);
      if (img[0].x < 0 || img[0].y < 0 || img[0].x > 799 || img[0].y > 599) continue;
      const auto got = map.pixelToRobot({img[0].x, img[0].y}, h);
      ASSERT_TRUE(got);
      const double e = (Eigen::Vector3d(got->x, got->y, got->z) - pb).norm();
      (h == 0 ? worst0 : worst25) = std::max(h == 0 ? worst0 : worst25, e);
      // The inverse for overlays lands on the same pixel.
      const auto back = map.robotToPixel(*got);
      ASSERT_TRUE(back);
      EXPECT_NEAR(back->u, img[0].x, 1e-6);
      EXPECT_NEAR(back->v, img[0].y, 1e-6);
    }
  }
  EXPECT_LT(worst0, 0.05);
  EXPECT_LT(worst25, 0.05);
}

TEST(calib_mapping, ignoring_distortion_would_miss_the_bound) {
  // The same cell mapped without the distortion model (what PinholePlaneModel does): the
  // corners of the image are millimetres off, which is why the mapping undistorts.
  const CalibratedCell c = calibrateCell();
  calib::CameraIntrinsics noDist = c.cam;
  noDist.dist = cv::Vec<double, 5>(0, 0, 0, 0, 0);
  const calib::CameraPlaneMapping map(noDist, c.baseFromCamera, c.plane);
  const calib::CameraPlaneMapping good(c.cam, c.baseFromCamera, c.plane);
  const auto a = map.pixelToRobot({20, 20}, 0), b = good.pixelToRobot({20, 20}, 0);
  ASSERT_TRUE(a && b);
  EXPECT_GT(std::hypot(a->x - b->x, a->y - b->y), 1.0);
}

TEST(calib_mapping, plane_from_touched_points) {
  // Points on a plane tilted 2 deg about x, 10 mm up.
  std::vector<Vec3> pts;
  const double t = std::tan(2.0 * M_PI / 180);
  for (int i = 0; i < 13; ++i)
    for (int j = 0; j < 15; ++j) pts.push_back({300.0 + 20 * j, -120.0 + 20 * i, 10.0 + t * (-120.0 + 20 * i)});
  auto p = calib::planeFromPoints(pts);
  ASSERT_TRUE(p) << p.error().message;
  EXPECT_NEAR(p->normal.z, std::cos(2.0 * M_PI / 180), 1e-9);
  EXPECT_NEAR(p->normal.y, -std::sin(2.0 * M_PI / 180), 1e-9);
  EXPECT_LT(p->fitRmsMm, 1e-9);
  auto line = calib::planeFromPoints({{0, 0, 0}, {1, 1, 1}, {2, 2, 2}});
  ASSERT_FALSE(line);
  EXPECT_NE(line.error().message.find("collinear"), std::string::npos);
  auto two = calib::planeFromPoints({{0, 0, 0}, {1, 1, 1}});
  ASSERT_FALSE(two);
  EXPECT_NE(two.error().message.find("at least 3"), std::string::npos);
}

TEST(calib_mapping, k_segment_curve_reproduces_a_polyline) {
  // Samples on a two-segment polyline in h: the fit puts its vertices on it.
  std::vector<double> h;
  std::vector<vision::PixelPoint> uv;
  for (int i = 0; i <= 8; ++i) {
    h.push_back(5.0 * i);
    const double x = i <= 4 ? 2.0 * i : 8.0 + 0.5 * (i - 4);
    uv.push_back({100 + x, 200 - x});
  }
  const auto c = calib::fitKSegmentCurve(h, uv, 2);
  ASSERT_EQ(c.knotH.size(), 3u);
  EXPECT_NEAR(c.knotH[1], 20.0, 1e-9);
  EXPECT_NEAR(c.at(10).u, 104.0, 1e-9);
  EXPECT_NEAR(c.at(35).u, 109.5, 1e-9);
  EXPECT_EQ(calib::fitKSegmentCurve(h, uv).knotH.size() - 1,  // default k = ceil(m^(1/3))
            static_cast<std::size_t>(std::ceil(std::cbrt(9.0))));
}

TEST(calib_mapping, multi_height_map_between_the_planes) {
  // Paper 001's procedure on a noise-free distorted camera looking straight down from 500 mm:
  // a 13 x 15 grid every 20 mm touched on 10 planes every 5 mm.
  const auto cam = sim::defaultCalibCamera();
  const se3::Iso baseCam = Eigen::Translation3d(400, 0, 500) * Eigen::AngleAxisd(M_PI, Eigen::Vector3d::UnitX());
  auto project = [&](const Eigen::Vector3d& pb) {
    const Eigen::Vector3d pc = baseCam.inverse() * pb;
    std::vector<cv::Point2d> img;
    cv::projectPoints(std::vector<cv::Point3d>{{pc.x(), pc.y(), pc.z()}}, cv::Vec3d(), cv::Vec3d(), cam.cameraMatrix,
                      cam.dist, img);
    return vision::PixelPoint{img[0].x, img[0].y};
  };
  const int rows = 13, cols = 15;
  std::vector<Vec3> grid;
  for (int r = 0; r < rows; ++r)
    for (int c = 0; c < cols; ++c) grid.push_back({400 - 140 + 20.0 * c, -120 + 20.0 * r, 0});
  std::vector<double> heights;
  std::vector<std::vector<vision::PixelPoint>> image;
  for (int k = 0; k < 10; ++k) {
    heights.push_back(5.0 * (k + 1));
    std::vector<vision::PixelPoint> plane;
    for (const auto& g : grid) plane.push_back(project({g.x, g.y, heights.back()}));
    image.push_back(plane);
  }
  auto m = calib::MultiHeightMap::build(rows, cols, grid, {0, 0, 1}, heights, image);
  ASSERT_TRUE(m) << m.error().message;
  EXPECT_EQ(m->segments(), 3);  // ceil(10^(1/3))
  // On a calibrated plane, at a grid point: only the curve's fit residual (3 segments for 10
  // samples smooth the perspective curvature in h a little).
  const auto at = m->pixelToRobot(project({420, 20, 25}), 25);
  ASSERT_TRUE(at);
  EXPECT_NEAR(at->x, 420, 0.01);
  EXPECT_NEAR(at->y, 20, 0.01);
  // Between grid points and between planes: the interpolation error (quantified in
  // docs/calibration.md) stays well under a millimetre on this 20 mm grid.
  double worst = 0;
  for (double x = 275; x < 530; x += 17)
    for (double y = -110; y < 110; y += 13) {
      const auto p = m->pixelToRobot(project({x, y, 8}), 8);
      ASSERT_TRUE(p) << x << " " << y;
      worst = std::max(worst, std::hypot(p->x - x, p->y - y));
    }
  EXPECT_LT(worst, 0.5);
  EXPECT_FALSE(m->pixelToRobot({2, 2}, 8));  // outside the grid: no answer, not a guess
  // Inconsistent input is named.
  image[3].pop_back();
  auto bad = calib::MultiHeightMap::build(rows, cols, grid, {0, 0, 1}, heights, image);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("plane 3"), std::string::npos) << bad.error().message;
}

}  // namespace
