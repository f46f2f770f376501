// vision/cloud/ (paper 004, docs/3d.md) against the depth renderer's ground truth
// (sim/depth_scene.hpp): depth -> cloud, plane removal, FPFH + RANSAC + ICP localisation of
// each part within 2 mm / 2 deg, the fitness thresholds f_l / f_h and the typed retry
// outcome, no pose on empty scenes, and the input checks. Scenes are rendered at 320 x 240
// (f = 400 px: 1.4 mm per pixel on the bin floor) to keep each test to a few seconds.
#include <cmath>
#include <string>
#include <utility>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "sim/depth_parts.hpp"
#include "sim/depth_render.hpp"
#include "sim/depth_scene.hpp"
#include "vision/cloud/cloud_math.hpp"
#include "vision/cloud/locator3d.hpp"
#include "vision/cloud/open3d_backend.hpp"

namespace {

using namespace vgr;
using vision::cloud::DepthIntrinsics;
using vision::cloud::Outcome3d;
using V3 = Eigen::Vector3d;

sim::DepthCameraModel smallCamera() {
  sim::DepthCameraModel c;
  c.width = 320;
  c.height = 240;
  c.fx = c.fy = 400;
  c.cx = 159.5;
  c.cy = 119.5;
  return c;
}

DepthIntrinsics intrinsicsOf(const sim::DepthCameraModel& c) { return {c.fx, c.fy, c.cx, c.cy, c.width, c.height}; }

vision::PlyCloud modelOf(const std::string& part) {
  auto p = sim::depthPart(part);
  EXPECT_TRUE(p.has_value());
  vision::PlyCloud m;
  for (const auto& s : sim::sampleSurface(*p, 1.0)) {
    m.points.push_back({s.x, s.y, s.z});
    m.normals.push_back({s.nx, s.ny, s.nz});
  }
  return m;
}

// The job defaults, fewer RANSAC iterations, and an ROI box inside the bin as a 3D job sets
// it (docs/3d.md "Parameters"): the bin's walls (x +-190..198, y +-140..148 mm, the camera
// looking straight down) are outside it.
Search3dParams testParams() {
  Search3dParams p;
  p.ransacIterations = 5000;
  p.roi.xMin = -185, p.roi.xMax = 185, p.roi.yMin = -135, p.roi.yMax = 135;
  return p;
}

sim::DepthSceneOptions sceneOptions(const std::string& part) {
  sim::DepthSceneOptions o;
  o.part = part;
  o.camera = smallCamera();
  o.cameraTiltMaxDeg = 0;  // the ROI box above is the bin's inside
  return o;
}

Pose poseOf(const Eigen::Isometry3d& t) {
  const Eigen::Quaterniond q(t.linear());
  return {t.translation().x(), t.translation().y(), t.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

TEST(cloud_math, BackProjectionPutsEveryPixelOnTheRenderedPlane) {
  // A tilted plane 600 mm away, rendered exactly (no noise) and quantised to 0.1 mm.
  sim::TriMesh plane;
  plane.vertices = {{-3000, -3000, 0}, {3000, -3000, 0}, {3000, 3000, 0}, {-3000, 3000, 0}};
  plane.triangles = {{0, 1, 2}, {0, 2, 3}};
  Eigen::Isometry3d t = Eigen::Isometry3d::Identity();
  t.linear() = Eigen::AngleAxisd(0.3, V3(1, -1, 0).normalized()).toRotationMatrix();
  t.translation() = V3(15, -10, 600);
  const auto cam = smallCamera();
  sim::ExactDepth e;
  sim::rasterize({{&plane, poseOf(t), 1}}, cam, e);
  sim::DepthSensorOptions quiet;
  quiet.noiseMmAt500 = 0;
  quiet.dropout = 0;
  const cv::Mat mm = sim::depthToMm(sim::applySensor(e, cam, quiet, 1), cam.depthScaleMm);
  const auto pts = vision::cloud::backProject(mm, intrinsicsOf(cam), RoiBox{});
  ASSERT_EQ(pts.size(), static_cast<std::size_t>(cam.width * cam.height));
  const V3 n = t.linear() * V3::UnitZ();
  const double d = n.dot(t.translation());
  double worst = 0;
  for (const auto& p : pts) {
    const V3 ray = p / p.z();  // the pixel's ray with z = 1
    worst = std::max(worst, std::abs(p.z() - d / n.dot(ray)));  // the plane's exact z on that ray
  }
  // Quantisation to 0.1 mm moves z by at most 0.05 mm (float: + 1e-4).
  EXPECT_LT(worst, 0.0501);

  // The ROI box (camera frame) keeps exactly the points inside it; step 2 every 4th pixel.
  RoiBox roi;
  roi.xMin = -50, roi.xMax = 80, roi.yMin = -40, roi.yMax = 60;
  const auto inRoi = vision::cloud::backProject(mm, intrinsicsOf(cam), roi);
  ASSERT_FALSE(inRoi.empty());
  std::size_t expected = 0;
  for (const auto& p : pts) expected += p.x() >= -50 && p.x() <= 80 && p.y() >= -40 && p.y() <= 60;
  EXPECT_EQ(inRoi.size(), expected);
  EXPECT_EQ(vision::cloud::backProject(mm, intrinsicsOf(cam), RoiBox{}, 2).size(),
            static_cast<std::size_t>(cam.width * cam.height / 4));
}

TEST(cloud_backend, PlaneRansacFindsTheBinFloorUnderPartsAndClutter) {
  // An empty-of-parts bin scene seen from above with the camera tilted: the bin floor is the
  // dominant plane; the true floor is z = floorMm in the bin frame, whose pose we do not
  // get, so check it against the floor's own pixels (label 0 at the far depth).
  auto o = sceneOptions("housing");  // camera straight down: the floor is z = floorMm
  auto s = sim::renderDepthScene(o, 3);
  ASSERT_TRUE(s.has_value());
  const cv::Mat mm = sim::depthToMm(s->depth, o.camera.depthScaleMm);
  const auto pts = vision::cloud::backProject(mm, intrinsicsOf(o.camera), RoiBox{});
  vision::cloud::backend::setThreads(1);
  vision::cloud::backend::seedRandom(1);
  const auto plane = vision::cloud::backend::PointSet(pts).segmentPlane(2.0, 200);
  Eigen::Vector4d c = plane.coefficients;
  if (c[3] < 0) c = -c;
  // Normal along -z (towards the camera), at the floor's distance.
  EXPECT_GT(-c[2], std::cos(0.5 * M_PI / 180));
  EXPECT_NEAR(-c[3] / c[2], o.floorMm, 0.5);
  // Every inlier is within the threshold; the part's pixels are not inliers.
  std::size_t onPart = 0;
  for (std::size_t i : plane.inliers) EXPECT_LT(std::abs(c.head<3>().dot(pts[i]) + c[3]), 2.0 + 1e-9);
  // Pixels of the part (label > 0) map back to points; count inliers among them.
  int idx = 0;
  std::vector<char> isPart(pts.size(), 0);
  for (int v = 0; v < mm.rows; ++v)
    for (int u = 0; u < mm.cols; ++u)
      if (mm.at<float>(v, u) > 0) isPart[static_cast<std::size_t>(idx++)] = s->labels.at<std::uint16_t>(v, u) > 0;
  for (std::size_t i : plane.inliers) onPart += isPart[i];
  EXPECT_LT(onPart, 0.02 * static_cast<double>(plane.inliers.size()));
  EXPECT_GT(plane.inliers.size(), pts.size() / 3);
}

struct Tally {
  int found = 0, correct = 0, wrong = 0, retry = 0, notFound = 0;
  double worstMm = 0, worstDeg = 0;
};

// Locates in scenes [first, first + n) and compares every returned pose with the truth.
Tally run(vision::cloud::Locator3d& loc, const sim::DepthSceneOptions& o, int first, int n) {
  Tally t;
  for (int i = first; i < first + n; ++i) {
    auto s = sim::renderDepthScene(o, static_cast<std::uint64_t>(i));
    EXPECT_TRUE(s.has_value());
    if (!s) continue;
    auto r = loc.locate(sim::depthToMm(s->depth, o.camera.depthScaleMm), intrinsicsOf(o.camera));
    EXPECT_TRUE(r.has_value()) << (r ? "" : r.error().message);
    if (!r) continue;
    if (r->outcome == Outcome3d::RetryFromNewViewpoint) ++t.retry;
    if (r->outcome == Outcome3d::NotFound) ++t.notFound;
    for (const auto& part : r->parts) {
      ++t.found;
      double bestMm = 1e9, bestDeg = 1e9;
      for (const auto& truth : s->parts) {
        const auto a = vision::cloud::toMatrix(part.pose), b = vision::cloud::toMatrix(truth.pose);
        const double mm = vision::cloud::translationErrorMm(a, b), deg = vision::cloud::rotationErrorDeg(a, b);
        if (mm + deg < bestMm + bestDeg) bestMm = mm, bestDeg = deg;
      }
      if (bestMm <= 2 && bestDeg <= 2) {
        ++t.correct;
        t.worstMm = std::max(t.worstMm, bestMm);
        t.worstDeg = std::max(t.worstDeg, bestDeg);
      } else {
        ++t.wrong;
        ADD_FAILURE() << o.part << " scene " << i << ": a pose " << bestMm << " mm / " << bestDeg << " deg from the truth";
      }
    }
  }
  return t;
}

class LocatePart : public ::testing::TestWithParam<std::string> {};

// The scenes as vgr-bench-cloud renders them (640 x 480, camera tilted up to 5 deg,
// bin walls in view, no ROI), scenes 0 and 2 of each part: every pose returned is within
// 2 mm / 2 deg. Measured with these parameters (vgr-bench-cloud --ransac-iterations 5000):
// bracket found in scene 2 only, housing in both, lever in scene 0 (scene 2: retry).
TEST_P(LocatePart, FindsThePartWithin2mmAnd2DegAndNeverReturnsAWrongPose) {
  Search3dParams p;
  p.ransacIterations = 5000;
  auto loc = vision::cloud::makeLocator3d(modelOf(GetParam()), Pose{}, p);
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  sim::DepthSceneOptions o;
  o.part = GetParam();
  Tally t = run(**loc, o, 0, 1);
  const Tally t2 = run(**loc, o, 2, 1);
  t.found += t2.found, t.correct += t2.correct, t.wrong += t2.wrong, t.retry += t2.retry, t.notFound += t2.notFound;
  t.worstMm = std::max(t.worstMm, t2.worstMm), t.worstDeg = std::max(t.worstDeg, t2.worstDeg);
  EXPECT_EQ(t.wrong, 0);
  EXPECT_GE(t.correct, GetParam() == "housing" ? 2 : 1) << "found " << t.found << ", retry " << t.retry << ", not found " << t.notFound;
  EXPECT_LE(t.worstMm, 2);
  EXPECT_LE(t.worstDeg, 2);
}

INSTANTIATE_TEST_SUITE_P(parts, LocatePart, ::testing::Values("bracket", "housing", "lever"));

// vgr-bench-cloud's scene 100 of each part (640 x 480, bin walls and clutter in view, no ROI,
// job defaults): the true pose within 2 mm / 2 deg, nothing else. Fails on the FPFH + RANSAC
// pipeline (bracket: not found, no RANSAC hypothesis within 15 mm / 15 deg of the truth);
// passes with the cluster search (docs/3d.md "Recall").
TEST(Locator3d, ClusterSearchFindsBenchScene100OfEachPart) {
  for (const char* part : {"bracket", "housing", "lever"}) {
    auto loc = vision::cloud::makeLocator3d(modelOf(part), Pose{}, Search3dParams{});
    ASSERT_TRUE(loc.has_value()) << loc.error().message;
    sim::DepthSceneOptions o;
    o.part = part;
    const Tally t = run(**loc, o, 100, 1);
    EXPECT_EQ(t.wrong, 0) << part;
    EXPECT_EQ(t.correct, 1) << part << ": retry " << t.retry << ", not found " << t.notFound;
    EXPECT_LE(t.worstMm, 2) << part;
    EXPECT_LE(t.worstDeg, 2) << part;
  }
}

// Each bench scene (the job defaults, vgr-bench-cloud's renderer options) gives its true pose
// within maxMm / maxDeg and nothing else.
void expectBenchScenesFound(const std::vector<std::pair<const char*, int>>& cases, double maxMm, double maxDeg) {
  for (const auto& [part, scene] : cases) {
    auto loc = vision::cloud::makeLocator3d(modelOf(part), Pose{}, Search3dParams{});
    ASSERT_TRUE(loc.has_value()) << loc.error().message;
    sim::DepthSceneOptions o;
    o.part = part;
    const Tally t = run(**loc, o, scene, 1);
    EXPECT_EQ(t.wrong, 0) << part << " " << scene;
    EXPECT_EQ(t.correct, 1) << part << " " << scene << ": retry " << t.retry << ", not found " << t.notFound;
    EXPECT_LE(t.worstMm, maxMm) << part << " " << scene;
    EXPECT_LE(t.worstDeg, maxDeg) << part << " " << scene;
  }
}

// Orientation (issue 13's 0.5 deg mean, issue 14's 1 deg bar): the bench scenes whose turn
// about the view axis was off the most, each within 1 deg and 1 mm. Before the degeneracy-
// aware refinement and the sub-pixel silhouette alignment: housing 123 1.98 deg (the final
// ICP turned it 0.1 -> 3.9 deg), bracket 105 1.15 deg, bracket 127 1.52 deg; after 0.1-0.6.
// Housing 139: no candidate consistent with the view among the 3 best hypotheses (the near-
// truth one ranks lower); the second round finds it (docs/3d.md "Recall and speed").
TEST(Locator3d, BenchScenesWithinOneDegreeAndSecondRoundRecall) {
  const std::vector<std::pair<const char*, int>> cases = {{"housing", 123}, {"bracket", 105}, {"bracket", 127}, {"housing", 139}};
  expectBenchScenesFound(cases, 1, 1);
}

// Recall, fourth pass (docs/3d.md "Recall (issue 13, fourth pass)"): the bench scenes the
// third pass missed, each now the true pose within 2 mm / 2 deg and nothing else. All failed
// before (not found): lever 142 / 147 touch the bin wall and formed one cluster with all the
// walls (fixed by leaving the walls out of the clusters); bracket 120 and housing 319 had a
// single near-truth PPF peak on a cluster of 135 / 154 points; bracket 326 and housing 336
// had their near-truth hypothesis at vote rank 13-22 (both fixed by the second round, run
// when nothing reaches f_h: every cluster point a reference, the 24 most voted re-ranked).
TEST(Locator3d, BenchScenesMissedByTheThirdPassAreFound) {
  const std::vector<std::pair<const char*, int>> cases = {{"lever", 142},   {"lever", 147},   {"bracket", 120},
                                               {"housing", 319}, {"bracket", 326}, {"housing", 336}};
  expectBenchScenesFound(cases, 2, 2);
}

TEST(Locator3d, NoPoseOnEmptyScenes) {
  auto loc = vision::cloud::makeLocator3d(modelOf("housing"), Pose{}, testParams());
  ASSERT_TRUE(loc.has_value());
  auto o = sceneOptions("housing");
  o.emptyRatio = 1;
  o.clutter = 10;
  const Tally t = run(**loc, o, 0, 4);
  EXPECT_EQ(t.found, 0);
  EXPECT_EQ(t.retry + t.notFound, 4);
}

TEST(Locator3d, FitnessThresholdsGiveFoundRefinedOrRetry) {
  // A board hides half of the part: what the view shows covers about half of what it should
  // (640 x 480, as vgr-bench-cloud --part housing --occlusion 0.5).
  sim::DepthSceneOptions o;
  o.part = "housing";
  o.occlusion = 0.5;
  auto s = sim::renderDepthScene(o, 0);
  ASSERT_TRUE(s.has_value());
  const cv::Mat mm = sim::depthToMm(s->depth, o.camera.depthScaleMm);
  const auto truth = vision::cloud::toMatrix(s->parts.front().pose);

  // f_l below the visible share: found, between f_l and f_h (refined), at the true pose.
  Search3dParams low;
  low.ransacIterations = 5000;
  low.fLow = 0.2;
  low.retryMinFitness = 0.1;
  auto a = vision::cloud::makeLocator3d(modelOf("housing"), Pose{}, low);
  ASSERT_TRUE(a.has_value());
  auto ra = (*a)->locate(mm, intrinsicsOf(o.camera));
  ASSERT_TRUE(ra.has_value());
  ASSERT_EQ(ra->outcome, Outcome3d::Found) << ra->reason;
  ASSERT_EQ(ra->parts.size(), 1u);
  const double fitness = ra->parts[0].fitness;
  EXPECT_LT(fitness, low.fHigh);
  EXPECT_TRUE(ra->parts[0].refined);
  EXPECT_LE(vision::cloud::translationErrorMm(vision::cloud::toMatrix(ra->parts[0].pose), truth), 2);
  EXPECT_LE(vision::cloud::rotationErrorDeg(vision::cloud::toMatrix(ra->parts[0].pose), truth), 2);

  // f_l above it: no pose, the typed "retry from a new viewpoint" outcome.
  Search3dParams high = low;
  high.fLow = std::min(1.0, fitness + 0.15);
  high.fHigh = std::max(high.fHigh, high.fLow);
  high.retryMinFitness = 0.1;
  auto b = vision::cloud::makeLocator3d(modelOf("housing"), Pose{}, high);
  ASSERT_TRUE(b.has_value());
  auto rb = (*b)->locate(mm, intrinsicsOf(o.camera));
  ASSERT_TRUE(rb.has_value());
  EXPECT_EQ(rb->outcome, Outcome3d::RetryFromNewViewpoint) << rb->reason;
  EXPECT_TRUE(rb->parts.empty());
  EXPECT_EQ(vision::cloud::outcomeName(rb->outcome), "retry_new_viewpoint");
}

TEST(Locator3d, MostlyHiddenPartIsRetryOrCorrectNeverWrong) {
  auto loc = vision::cloud::makeLocator3d(modelOf("lever"), Pose{}, testParams());
  ASSERT_TRUE(loc.has_value());
  auto o = sceneOptions("lever");
  o.occlusion = 0.8;
  const Tally t = run(**loc, o, 0, 3);
  EXPECT_EQ(t.wrong, 0);
  EXPECT_EQ(t.correct + t.retry + t.notFound, 3);
}

TEST(Locator3d, RejectsBadModelsParametersAndImages) {
  auto noNormals = modelOf("lever");
  noNormals.normals.clear();
  auto e1 = vision::cloud::makeLocator3d(noNormals, Pose{}, testParams());
  ASSERT_FALSE(e1.has_value());
  EXPECT_NE(e1.error().message.find("normals"), std::string::npos);

  vision::PlyCloud tiny = modelOf("lever");
  tiny.points.resize(50);
  tiny.normals.resize(50);
  EXPECT_FALSE(vision::cloud::makeLocator3d(tiny, Pose{}, testParams()).has_value());

  Search3dParams bad = testParams();
  bad.fHigh = 0.3;  // below f_l
  auto e3 = vision::cloud::makeLocator3d(modelOf("lever"), Pose{}, bad);
  ASSERT_FALSE(e3.has_value());
  EXPECT_NE(e3.error().message.find("f_h"), std::string::npos) << e3.error().message;

  auto loc = vision::cloud::makeLocator3d(modelOf("lever"), Pose{}, testParams());
  ASSERT_TRUE(loc.has_value());
  const auto k = intrinsicsOf(smallCamera());
  EXPECT_FALSE((*loc)->locate(cv::Mat(240, 320, CV_8UC1, cv::Scalar(100)), k).has_value());      // 8-bit
  EXPECT_FALSE((*loc)->locate(cv::Mat(240, 320, CV_32FC3, cv::Scalar(500, 500, 500)), k).has_value());  // colour
  EXPECT_FALSE((*loc)->locate(cv::Mat(240, 320, CV_32FC1, cv::Scalar(0)), k).has_value());       // all invalid
  EXPECT_FALSE((*loc)->locate(cv::Mat(120, 160, CV_32FC1, cv::Scalar(500)), k).has_value());     // size
}

}  // namespace
