// Grasp detection (vision/grasp/): the floor and height map, the network's input and
// targets, the rectangle metric, both detectors, bad input, and grasps in the robot frame.
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <utility>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>
#include <unistd.h>

#include "sim/depth_parts.hpp"
#include "sim/depth_render.hpp"
#include "sim/depth_scene.hpp"
#include "sim/grasp_truth.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/calib/plane_model.hpp"
#include "vision/grasp/grasp_detector.hpp"
#include "vision/grasp/grasp_input.hpp"
#include "vision/grasp/grasp_metrics.hpp"
#include "vision/grasp/grasp_pose.hpp"
#include "vision/grasp/height_map.hpp"

namespace {

using namespace vgr::vision::grasp;
using V3 = Eigen::Vector3d;
namespace sim = vgr::sim;

const std::string kModel = std::string(VGR_SOURCE_DIR) + "/models/grasp/ggcnn.onnx";

vgr::Pose poseOf(const Eigen::Isometry3d& t) {
  Eigen::Quaterniond q(t.linear());
  if (q.w() < 0) q.coeffs() *= -1;
  return {t.translation().x(), t.translation().y(), t.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

sim::TriMesh box(V3 lo, V3 hi) { return sim::boxMesh(std::array<double, 3>{lo.x(), lo.y(), lo.z()}, std::array<double, 3>{hi.x(), hi.y(), hi.z()}); }

// The camera of sim/depth_scene.cpp straight down on the bin frame (z up, floor z = 0).
Eigen::Isometry3d camFromBin() {
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = V3(1, -1, -1).asDiagonal();
  t.translation() = V3(0, 0, 560);
  return t;
}

DepthIntrinsics intrinsicsOf(const sim::DepthCameraModel& c) { return {c.width, c.height, c.fx, c.fy, c.cx, c.cy}; }

DepthFrame frameOf(const cv::Mat& depth16, const sim::DepthCameraModel& c, const std::string& name = "scene") {
  return {sim::depthToMm(depth16, c.depthScaleMm), intrinsicsOf(c), name};
}

// A 40 x 20 x 20 mm block on the floor, turned 30 deg about the floor normal, centred at
// (30, -20) mm in the bin frame, with the sensor's noise, dropout and invalid edges.
DepthFrame blockFrame() {
  const sim::TriMesh floor = box({-400, -300, -10}, {400, 300, 0});
  const sim::TriMesh block = box({-20, -10, 0}, {20, 10, 20});
  Eigen::Isometry3d binFromBlock = Eigen::Isometry3d::Identity();
  binFromBlock.linear() = Eigen::AngleAxisd(30 * M_PI / 180, V3::UnitZ()).toRotationMatrix();
  binFromBlock.translation() = V3(30, -20, 0);
  sim::DepthCameraModel cam;
  sim::ExactDepth e;
  sim::rasterize({{&floor, poseOf(camFromBin()), 0}, {&block, poseOf(camFromBin() * binFromBlock), 1}}, cam, e);
  return frameOf(sim::applySensor(e, cam, {}, 7), cam, "block");
}

TEST(grasp_floor, FitsTheFloorUnderAStraightDownCameraWithinAFractionOfAMillimetre) {
  auto f = fitFloorPlane(blockFrame().zMm, intrinsicsOf({}), "block");
  ASSERT_TRUE(f) << f.error().message;
  EXPECT_NEAR(f->nz, -1, 1e-5);  // within 0.26 deg of the optical axis
  EXPECT_NEAR(f->depthAtPrincipalPoint(), 560, 0.3);
  EXPECT_GT(f->inlierShare, 0.8);
  const cv::Mat h = heightAboveFloor(blockFrame().zMm, intrinsicsOf({}), *f);
  // the block's top, 20 mm high, at the projection of its centre (30, 20, 540) in the camera
  EXPECT_NEAR(h.at<float>(static_cast<int>(std::lround(800 * 20 / 540.0 + 239.5)), static_cast<int>(std::lround(800 * 30 / 540.0 + 319.5))), 20, 1.5);

  cv::Mat noise(480, 640, CV_32FC1);
  cv::randu(noise, 300, 900);
  auto none = fitFloorPlane(noise, intrinsicsOf({}), "noise.png");
  ASSERT_FALSE(none);
  EXPECT_EQ(none.error().message.rfind("noise.png: no floor plane", 0), 0u) << none.error().message;
}

TEST(grasp_input, HeightsOverFiftyMillimetresAtHalfResolutionPaddedToTheStride) {
  const DepthFrame f = blockFrame();
  auto floor = fitFloorPlane(f.zMm, f.camera, f.name);
  ASSERT_TRUE(floor);
  const auto scale = netScale(f.camera, *floor, f.name);
  ASSERT_TRUE(scale) << scale.error().message;
  EXPECT_DOUBLE_EQ(*scale, 0.5);  // 560 mm / 800 px / 1.4 mm per px
  // A camera that sees the floor at 5.6 mm per px (or 0.1): no input at 1.4 mm per px.
  DepthIntrinsics coarse = f.camera, fine = f.camera;
  coarse.fx = coarse.fy = 100;
  fine.fx = fine.fy = 4000;
  for (const auto& cam : {coarse, fine}) {
    const auto refused = netScale(cam, *floor, f.name);
    ASSERT_FALSE(refused);
    EXPECT_EQ(refused.error().message.rfind(f.name + ": the floor is 560 mm away at f = ", 0), 0u) << refused.error().message;
    EXPECT_NE(refused.error().message.find("outside [1/8, 1]"), std::string::npos) << refused.error().message;
  }
  const NetInput in = makeNetInput(heightAboveFloor(f.zMm, f.camera, *floor), 0.5);
  EXPECT_EQ(in.rows, 240);
  EXPECT_EQ(in.cols, 320);
  EXPECT_EQ(in.tensor.rows, 240);
  EXPECT_EQ(in.tensor.cols, 324);
  EXPECT_EQ(cv::countNonZero(in.tensor != in.tensor), 0) << "no NaN";
  EXPECT_NEAR(in.tensor.at<float>(30, 30), 0, 0.02) << "the floor";
  const double u = imageToNet(800 * 30 / 540.0 + 319.5, in.scaleX), v = imageToNet(800 * 20 / 540.0 + 239.5, in.scaleY);
  EXPECT_NEAR(in.tensor.at<float>(static_cast<int>(std::lround(v)), static_cast<int>(std::lround(u))), 20.0 / 50, 0.02);
  EXPECT_EQ(in.tensor.at<float>(100, 323), in.tensor.at<float>(100, 319)) << "padding replicates the border";
}

TEST(grasp_input, TargetsAreAGaussianAcrossTheLineOfTrueCentresWithAngleAndWidth) {
  NetInput in;
  in.tensor = cv::Mat::zeros(48, 60, CV_32FC1);
  in.rows = 48, in.cols = 60, in.scaleX = in.scaleY = 0.5;
  // 36 px wide at 30 deg; 1.5 image px per mm: sigma 2 mm = 1.5 network px, +- 1 mm = 0.75 px along
  const auto maps = drawNetTargets({{50.5, 40.5, 30, 36, 1.5, 2}}, in);
  const cv::Point c(25, 20);  // imageToNet(50.5) = 25, imageToNet(40.5) = 20
  EXPECT_FLOAT_EQ(maps[0].at<float>(c), 1);
  EXPECT_NEAR(maps[1].at<float>(c), std::cos(60 * M_PI / 180), 1e-6);
  EXPECT_NEAR(maps[2].at<float>(c), std::sin(60 * M_PI / 180), 1e-6);
  EXPECT_NEAR(maps[3].at<float>(c), 18 / kNetWidthScalePx, 1e-6);
  // across the line (the closing axis: (cos 30, -sin 30) in the image), a Gaussian of sigma 1.5 px
  const double th = 30 * M_PI / 180;
  for (double d : {1.0, 2.0, 3.0}) {
    const double x = c.x + d * std::cos(th), y = c.y - d * std::sin(th);
    const int xi = static_cast<int>(std::lround(x)), yi = static_cast<int>(std::lround(y));
    // the pixel's own distance to the line (it is not exactly on the axis)
    const cv::Point2d off(xi - c.x, yi - c.y), along(std::sin(th), std::cos(th));
    const double t = std::clamp(off.dot(along), -0.75, 0.75);
    const cv::Point2d perp = off - along * t;
    EXPECT_NEAR(maps[0].at<float>(yi, xi), std::exp(-perp.dot(perp) / (2 * 1.5 * 1.5)), 1e-5) << d;
  }
  EXPECT_EQ(maps[0].at<float>(20, 40), 0) << "far from the grasp";
  EXPECT_EQ(maps[3].at<float>(20, 40), 0);
  EXPECT_EQ(cv::countNonZero(maps[0]), cv::countNonZero(maps[3])) << "angle and width exactly where quality is";
}

TEST(grasp_metrics, IouAndAngleOfGraspRectangles) {
  const GraspRect a{100, 100, 0, 30, 10};
  EXPECT_NEAR(rectIou(a, a), 1, 1e-6);
  EXPECT_NEAR(rectIou(a, {115, 100, 0, 30, 10}), 1.0 / 3, 1e-4);  // shifted half a width
  EXPECT_NEAR(rectIou(a, {100, 100, 90, 30, 10}), 100.0 / 500, 1e-4);
  EXPECT_EQ(rectIou(a, {200, 100, 0, 30, 10}), 0);
  EXPECT_NEAR(angleDiffDeg(89, -89), 2, 1e-12);
  EXPECT_NEAR(angleDiffDeg(10, 190), 0, 1e-12);
  EXPECT_NEAR(angleDiffDeg(0, 90), 90, 1e-12);
  EXPECT_NEAR(angleDiffDeg(-30, 30), 60, 1e-12);
}

TEST(grasp_metrics, ScoresByRectangleMetricAndDistanceToTheLineOfTrueCentres) {
  // One canonical grasp sampled at three centres 3 px apart along x, closing along image y.
  std::vector<TruthRect> truth;
  for (int k = 0; k < 3; ++k) truth.push_back({{100.0 + 3 * k, 100, 90, 20, 14}, 560, 800, 0, k});
  auto s = scoreGrasp({104.5, 101, 80, 22, 14}, truth);
  EXPECT_TRUE(s.rectSuccess);
  EXPECT_NEAR(s.posErrMm, 1 * 560.0 / 800, 1e-9) << "1 px off the line between samples 1 and 2";
  EXPECT_NEAR(s.angleErrDeg, 10, 1e-9);
  EXPECT_FALSE(scoreGrasp({104.5, 101, 50, 22, 14}, truth).rectSuccess) << "40 deg off";
  EXPECT_FALSE(scoreGrasp({104.5, 125, 90, 20, 14}, truth).rectSuccess) << "a jaw length off";
  EXPECT_FALSE(scoreGrasp({104.5, 101, 90, 20, 14}, {}).rectSuccess);
  // a gap in the samples is no line: the distance is to the nearest sample then
  truth.erase(truth.begin() + 1);
  EXPECT_NEAR(scoreGrasp({103, 100, 90, 20, 14}, truth).posErrMm, 3 * 560.0 / 800, 1e-9);
}

TEST(grasp_analytic, GripsABlockAcrossItsShortSideAtItsCentre) {
  GraspDetectorOptions o;
  o.detector = "analytic";
  auto det = makeGraspDetector(o);
  ASSERT_TRUE(det) << det.error().message;
  auto g = (*det)->detect(blockFrame());
  ASSERT_TRUE(g) << g.error().message;
  ASSERT_EQ(g->size(), 1u);
  const Grasp& best = g->front();
  EXPECT_NEAR(best.u, 800 * 30 / 540.0 + 319.5, 1.0);
  EXPECT_NEAR(best.v, 800 * 20 / 540.0 + 239.5, 1.0);
  // the short side (block y) turned 30 deg about the floor normal: (-sin 30, cos 30) in the
  // bin frame is (-0.5, -0.87) in the image, -60 deg counter-clockwise as displayed
  EXPECT_LT(angleDiffDeg(best.angleDeg, -60), 2);
  EXPECT_NEAR(best.widthMm, 20 + 2 * 2, 1.5);
  EXPECT_NEAR(best.depthMm, 540, 1);
  EXPECT_NEAR(best.heightMm, 20, 1);
}

TEST(grasp_detector, UnknownNamesAndOptionsOutOfRangeAreRefused) {
  GraspDetectorOptions o;
  o.detector = "magic";
  auto d = makeGraspDetector(o);
  ASSERT_FALSE(d);
  EXPECT_NE(d.error().message.find("unknown grasp detector 'magic'"), std::string::npos);
  o.detector = "analytic";
  o.gripper.maxOpeningMm = -1;
  EXPECT_FALSE(makeGraspDetector(o));
  o = {};
  o.detector = "ggcnn";
  o.modelPath.clear();
  d = makeGraspDetector(o);
  ASSERT_FALSE(d);
  EXPECT_NE(d.error().message.find("needs a model"), std::string::npos);
}

std::string tempPath(const std::string& name) {
  return (std::filesystem::temp_directory_path() / (std::to_string(::getpid()) + "-" + name)).string();
}

TEST(grasp_ggcnn, AnOnnxFileThatDoesNotLoadIsOneLineNamingIt) {
  GraspDetectorOptions o;
  o.modelPath = tempPath("garbage.onnx");
  {
    std::ofstream(o.modelPath) << "this is not a protobuf\n\x01\x02\x03";
  }
  auto d = makeGraspDetector(o);
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().message.rfind(o.modelPath + ": cannot load the grasp network: ", 0), 0u) << d.error().message;
  EXPECT_EQ(d.error().message.find('\n'), std::string::npos);
  std::filesystem::remove(o.modelPath);

  o.modelPath = tempPath("missing.onnx");
  d = makeGraspDetector(o);
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().message, o.modelPath + ": no such file");

  o.modelPath = std::string(VGR_SOURCE_DIR) + "/tests/fixtures/one_map.onnx";  // loads, but 1 map out
  d = makeGraspDetector(o);
  ASSERT_FALSE(d);
  EXPECT_EQ(d.error().message.rfind(o.modelPath + ": not a grasp network: ", 0), 0u) << d.error().message;
  EXPECT_EQ(d.error().message.find('\n'), std::string::npos);
}

TEST(grasp_ggcnn, ADepthImageOfTheWrongSizeOrTypeIsOneLineNamingIt) {
  GraspDetectorOptions o;
  o.modelPath = kModel;
  for (const char* name : {"ggcnn", "analytic"}) {
    o.detector = name;
    auto d = makeGraspDetector(o);
    ASSERT_TRUE(d) << d.error().message;
    DepthFrame f = blockFrame();
    f.name = "images/0007.png";
    cv::Mat small;
    cv::resize(f.zMm, small, cv::Size(320, 240), 0, 0, cv::INTER_NEAREST);
    f.zMm = small;
    auto g = (*d)->detect(f);
    ASSERT_FALSE(g) << name;
    EXPECT_EQ(g.error().message, "images/0007.png: 320x240 px, but the camera is 640x480 (camera.yaml)");
    f = blockFrame();
    f.name = "images/0008.png";
    f.zMm.convertTo(f.zMm, CV_16UC1, 10);
    g = (*d)->detect(f);
    ASSERT_FALSE(g) << name;
    EXPECT_EQ(g.error().message.rfind("images/0008.png: expected a depth image in mm", 0), 0u) << g.error().message;
  }
}

// tests/fixtures/height_as_quality.onnx: quality = the input (height / 50 mm), cos 2 theta = 1,
// sin 2 theta = 0, width 20 network px: its best peak is the highest point. A 100 mm bar (a
// bin wall) next to the 20 mm block: the wall outbids the block, and the detector must drop
// it for standing higher than maxObjectHeightMm (80 mm), keeping the block.
TEST(grasp_ggcnn, AGraspHigherThanAnyPartStandsIsDropped) {
  const sim::TriMesh floor = box({-400, -300, -10}, {400, 300, 0});
  const sim::TriMesh block = box({-20, -10, 0}, {20, 10, 20});
  const sim::TriMesh wall = box({-140, 80, 0}, {140, 90, 100});
  Eigen::Isometry3d binFromBlock = Eigen::Isometry3d::Identity();
  binFromBlock.translation() = V3(30, -20, 0);
  sim::DepthCameraModel cam;
  sim::ExactDepth e;
  sim::rasterize({{&floor, poseOf(camFromBin()), 0}, {&block, poseOf(camFromBin() * binFromBlock), 1}, {&wall, poseOf(camFromBin()), 2}},
                 cam, e);
  const DepthFrame f = frameOf(sim::applySensor(e, cam, {}, 7), cam, "wall");
  GraspDetectorOptions o;
  o.modelPath = std::string(VGR_SOURCE_DIR) + "/tests/fixtures/height_as_quality.onnx";
  o.minQuality = 0.2;
  // The fixture's opening (26 mm) is shorter than the block's and the wall's 40 and 280 mm
  // along its closing axis: the jaw check would drop both; this test is about the height bound.
  o.checkJaws = false;
  for (const double maxHeight : {80.0, 200.0}) {
    o.maxObjectHeightMm = maxHeight;
    auto det = makeGraspDetector(o);
    ASSERT_TRUE(det) << det.error().message;
    auto g = (*det)->detect(f);
    ASSERT_TRUE(g) << g.error().message;
    ASSERT_FALSE(g->empty()) << maxHeight;
    for (const auto& gr : *g) EXPECT_LE(gr.heightMm, maxHeight + 1e-9);
    if (maxHeight == 80) {
      EXPECT_NEAR(g->front().heightMm, 20, 2) << "the block";
      EXPECT_NEAR(g->front().u, 800 * 30 / 540.0 + 319.5, 12);
      EXPECT_NEAR(g->front().v, 800 * 20 / 540.0 + 239.5, 12);
    } else {
      EXPECT_NEAR(g->front().heightMm, 100, 2) << "without the bound the wall comes first";
    }
  }
}

// The jaw check (docs/grasp.md "Network") with the fixture above, which closes along image x
// with a 40 px (26 mm at the block's top) opening. Across a 20 mm side of a block the opening
// read from the height map is the side and both clearances, centred on the block, and the
// network's 26 mm nearly agree; across a 40 mm side the network's opening would put both jaws
// on the block: read, it is 44 mm, and the grasp's quality drops with the disagreement (without
// the check the detector keeps the network's 26 mm, a grasp whose jaws land on the block).
TEST(grasp_ggcnn, TheJawsOpeningIsReadFromTheHeightMapAndWeighsTheQuality) {
  const sim::TriMesh floor = box({-400, -300, -10}, {400, 300, 0});
  sim::DepthCameraModel cam;
  auto frameWith = [&](const sim::TriMesh& block) {
    Eigen::Isometry3d binFromBlock = Eigen::Isometry3d::Identity();
    binFromBlock.translation() = V3(30, -20, 0);
    sim::ExactDepth e;
    sim::rasterize({{&floor, poseOf(camFromBin()), 0}, {&block, poseOf(camFromBin() * binFromBlock), 1}}, cam, e);
    return frameOf(sim::applySensor(e, cam, {}, 7), cam, "block");
  };
  GraspDetectorOptions o;
  o.modelPath = std::string(VGR_SOURCE_DIR) + "/tests/fixtures/height_as_quality.onnx";
  auto best = [&](const DepthFrame& f) {
    auto det = makeGraspDetector(o);
    EXPECT_TRUE(det) << det.error().message;
    auto g = (*det)->detect(f);
    EXPECT_TRUE(g) << g.error().message;
    EXPECT_FALSE(g->empty());
    return g->empty() ? Grasp{} : g->front();
  };
  const double u0 = 800 * 30 / 540.0 + 319.5;  // the block's centre, px
  const DepthFrame narrow = frameWith(box({-10, -20, 0}, {10, 20, 20})), wide = frameWith(box({-20, -10, 0}, {20, 10, 20}));
  Grasp g = best(narrow);
  EXPECT_NEAR(g.heightMm, 20, 2);
  EXPECT_NEAR(g.widthMm, 20 + 2 * 2, 2) << "the side and both clearances";
  EXPECT_NEAR(g.u, u0, 3) << "centred between the faces";
  const double narrowQuality = g.quality;
  // The fixture's quality there is the height / 50 mm (0.4); 26 vs 24 mm within 5 mm: weighed by > exp(-0.5 (5/3)^2).
  EXPECT_GT(narrowQuality, 0.4 * std::exp(-0.5 * 25 / 9)) << "26 vs 24 mm agree";
  g = best(wide);
  EXPECT_NEAR(g.heightMm, 20, 2);
  EXPECT_NEAR(g.widthMm, 40 + 2 * 2, 2);
  EXPECT_NEAR(g.u, u0, 3);
  EXPECT_LT(g.quality, 0.01 * narrowQuality) << "26 vs 44 mm disagree";
  o.checkJaws = false;
  g = best(wide);
  EXPECT_NEAR(g.widthMm, 26, 2) << "unchecked: the network's opening, shorter than the block";
}

TEST(grasp_ggcnn, TheCommittedModelIsSmallAndBeatsTheBaselineOnHeldOutScenes) {
  ASSERT_TRUE(std::filesystem::is_regular_file(kModel)) << kModel << ": the committed model is missing";
  ASSERT_LE(std::filesystem::file_size(kModel), 1u << 20) << "the model file must stay <= 1 MB";
  GraspDetectorOptions o;
  o.modelPath = kModel;
  auto det = makeGraspDetector(o);
  ASSERT_TRUE(det) << det.error().message;
  o.detector = "analytic";
  auto base = makeGraspDetector(o);
  ASSERT_TRUE(base) << base.error().message;
  // 8 cluttered scenes per part with a seed no training or evaluation set uses
  // (models/grasp/train_ggcnn.py); the best grasp of each detector scored by the rectangle metric.
  int graspable = 0, success = 0, baseSuccess = 0;
  auto hit = [](const std::vector<Grasp>& g, const std::vector<TruthRect>& rects) {
    return !g.empty() && scoreGrasp({g.front().u, g.front().v, g.front().angleDeg, g.front().widthPx, g.front().jawPx}, rects).rectSuccess;
  };
  for (const auto& part : sim::depthPartNames()) {
    sim::DepthSceneOptions so;
    so.part = part;
    so.partsPerScene = 2;
    so.clutter = 6;
    so.seed = 77;
    for (std::uint64_t i = 0; i < 8; ++i) {
      auto scene = sim::renderDepthScene(so, i);
      ASSERT_TRUE(scene);
      auto truth = sim::sceneGraspTruth(*scene, part);
      ASSERT_TRUE(truth);
      if (truth->empty()) continue;
      std::vector<TruthRect> rects;
      std::map<std::pair<int, std::string>, int> lines;  // one polyline per line of one part
      for (const auto& t : *truth) {
        const int line = lines.emplace(std::make_pair(t.part, t.grasp), static_cast<int>(lines.size())).first->second;
        rects.push_back({{t.u, t.v, t.angleDeg, t.widthPx, t.jawPx}, t.centreCam.z, scene->camera.fx, line, t.sample});
      }
      ++graspable;
      const DepthFrame frame = frameOf(scene->depth, scene->camera);
      auto g = (*det)->detect(frame);
      ASSERT_TRUE(g) << g.error().message;
      success += hit(*g, rects);
      auto b = (*base)->detect(frame);
      ASSERT_TRUE(b) << b.error().message;
      baseSuccess += hit(*b, rects);
    }
  }
  ASSERT_GE(graspable, 18);
  std::printf("ggcnn %d, analytic %d of %d graspable scenes\n", success, baseSuccess, graspable);
  // The committed model's measured level on these scenes (docs/grasp.md "Measured": issue
  // 15's >= 90 % is NOT reached yet); a retrained model must not fall below it, nor below the
  // analytic baseline.
  // Measured 19 of 24 (analytic 14) with the committed model (2026-12-05 10:17, hard
  // negatives) and the jaw check; the model before it: 17 with the check, 17 without; 15 of 24
  // (analytic 8) against the old line truth at 0.4.
  EXPECT_GE(success, 19) << success << " of " << graspable;
  EXPECT_GT(success, baseSuccess) << "ggcnn " << success << ", analytic " << baseSuccess << " of " << graspable;
}

// The grasp in the robot frame: a true grasp (sim/grasp_truth.hpp) given to both mappings
// must land on the true centre, with the true opening and the canonical closing axis.
TEST(grasp_pose, TheThreeDAndThePlaneCalibrationPutATrueGraspOnItsCentre) {
  sim::DepthSceneOptions so;
  so.part = "lever";
  so.cameraTiltMaxDeg = 0;
  so.tiltMaxDeg = 0;
  so.clutter = 0;
  auto scene = sim::renderDepthScene(so, 3);
  ASSERT_TRUE(scene);
  auto truth = sim::sceneGraspTruth(*scene, "lever");
  ASSERT_TRUE(truth);
  ASSERT_FALSE(truth->empty());
  const sim::GraspTruth& t = truth->front();
  // The robot base: the bin frame (floor z = 0) turned 25 deg and moved; the camera above it.
  Eigen::Isometry3d baseFromBin = Eigen::Isometry3d::Identity();
  baseFromBin.linear() = Eigen::AngleAxisd(25 * M_PI / 180, V3::UnitZ()).toRotationMatrix();
  baseFromBin.translation() = V3(400, -150, 80);
  const Eigen::Isometry3d baseFromCam = baseFromBin * camFromBin().inverse();
  const V3 expect = baseFromCam * V3(t.centreCam.x, t.centreCam.y, t.centreCam.z);
  const auto& p = scene->parts[0].pose;
  const V3 closing = baseFromCam.linear() * (Eigen::Quaterniond(p.qw, p.qx, p.qy, p.qz) * V3::UnitY());  // the arm's closing axis
  double expectAngle = std::atan2(closing.y(), closing.x()) * 180 / M_PI;
  if (expectAngle > 90) expectAngle -= 180;
  if (expectAngle <= -90) expectAngle += 180;

  Grasp g;
  g.u = t.u, g.v = t.v, g.angleDeg = t.angleDeg, g.widthPx = t.widthPx, g.jawPx = t.jawPx;
  g.depthMm = t.centreCam.z;
  g.heightMm = 560 - t.centreCam.z;  // the camera looks straight down on a floor 560 mm away

  auto r3 = graspToRobot3d(g, intrinsicsOf(scene->camera), poseOf(baseFromCam));
  ASSERT_TRUE(r3) << r3.error().message;
  EXPECT_NEAR((V3(r3->centre.x, r3->centre.y, r3->centre.z) - expect).norm(), 0, 1e-6);
  EXPECT_NEAR(r3->widthMm, t.widthMm, 0.01);
  EXPECT_LT(angleDiffDeg(r3->angleDeg, expectAngle), 0.01);
  EXPECT_NEAR(r3->pose.x, expect.x(), 1e-6);

  const auto& c = scene->camera;
  const vgr::vision::PinholePlaneModel model(c.fx, c.fy, c.cx, c.cy, poseOf(baseFromCam), 80);  // floor at base z 80
  const auto mapping = vgr::vision::calib::pinholeMapping(model);
  auto rp = graspToRobotPlane(g, *mapping);
  ASSERT_TRUE(rp) << rp.error().message;
  EXPECT_NEAR((V3(rp->centre.x, rp->centre.y, rp->centre.z) - expect).norm(), 0, 1e-6);
  EXPECT_NEAR(rp->widthMm, t.widthMm, 0.01);
  EXPECT_LT(angleDiffDeg(rp->angleDeg, expectAngle), 0.01);

  g.depthMm = 0;
  EXPECT_FALSE(graspToRobot3d(g, intrinsicsOf(scene->camera), poseOf(baseFromCam)));
}

}  // namespace
