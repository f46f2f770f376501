// Grasp ground truth (sim/grasp_truth.hpp) from the part geometry and the scene, and its
// file grasps.csv (config/grasp_truth_file.hpp).
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>

#include <Eigen/Geometry>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <unistd.h>

#include "config/grasp_truth_file.hpp"
#include "sim/depth_parts.hpp"
#include "sim/depth_render.hpp"
#include "sim/depth_scene.hpp"
#include "sim/grasp_truth.hpp"

namespace {

using namespace vgr::sim;
using V3 = Eigen::Vector3d;

vgr::Pose poseOf(const Eigen::Isometry3d& t) {
  Eigen::Quaterniond q(t.linear());
  if (q.w() < 0) q.coeffs() *= -1;
  return {t.translation().x(), t.translation().y(), t.translation().z(), q.w(), q.x(), q.y(), q.z()};
}

TriMesh box(V3 lo, V3 hi) { return boxMesh(std::array<double, 3>{lo.x(), lo.y(), lo.z()}, std::array<double, 3>{hi.x(), hi.y(), hi.z()}); }

// `part` on a floor 560 mm below a camera looking straight down (the bin frame of
// sim/depth_scene.cpp: z up, camera = diag(1, -1, -1) at z 560), placed by binFromModel;
// `obstacles` in the part's model frame.
DepthScene partScene(const std::string& part, const Eigen::Isometry3d& binFromModel, const std::vector<TriMesh>& obstacles = {}) {
  const DepthPart model = *depthPart(part);
  const TriMesh floor = box({-400, -300, -10}, {400, 300, 0});
  Eigen::Isometry3d camFromBin = Eigen::Isometry3d::Identity();
  camFromBin.linear() = V3(1, -1, -1).asDiagonal();
  camFromBin.translation() = V3(0, 0, 560);
  DepthScene s;
  std::vector<MeshInstance> meshes{{&floor, poseOf(camFromBin), 0}, {&model.mesh, poseOf(camFromBin * binFromModel), 1}};
  for (const auto& o : obstacles) meshes.push_back({&o, poseOf(camFromBin * binFromModel), 0});
  ExactDepth e;
  rasterize(meshes, s.camera, e);
  s.exactZ = e.z;
  s.labels = e.labels;
  s.depth = applySensor(e, s.camera, {}, 1);
  DepthPartTruth t;
  t.pose = poseOf(camFromBin * binFromModel);
  s.parts.push_back(t);
  return s;
}

// A lever lying flat, turned by `tiltDeg` about its arm (model x) and lifted by `liftMm`.
DepthScene leverScene(double tiltDeg = 0, double liftMm = 0, const std::vector<TriMesh>& obstacles = {}) {
  Eigen::Isometry3d binFromModel = Eigen::Isometry3d::Identity();
  binFromModel.linear() = Eigen::AngleAxisd(tiltDeg * M_PI / 180, V3::UnitX()).toRotationMatrix();
  binFromModel.translation() = V3(0, 0, liftMm);
  return partScene("lever", binFromModel, obstacles);
}

std::set<int> samples(const std::vector<GraspTruth>& truth) {
  std::set<int> out;
  for (const auto& g : truth) out.insert(g.sample);
  return out;
}

TEST(grasp_truth, EveryPartHasCanonicalGraspsAcrossNarrowSections) {
  for (const auto& name : depthPartNames()) {
    auto g = canonicalGrasps(name);
    ASSERT_TRUE(g) << name;
    ASSERT_FALSE(g->empty()) << name;
    for (const auto& c : *g) {
      const V3 seg = V3(c.b[0], c.b[1], c.b[2]) - V3(c.a[0], c.a[1], c.a[2]);
      EXPECT_NEAR(V3(c.closing[0], c.closing[1], c.closing[2]).norm(), 1, 1e-12) << name << " " << c.name;
      EXPECT_NEAR(seg.dot(V3(c.closing[0], c.closing[1], c.closing[2])), 0, 1e-9) << name << " " << c.name;
      EXPECT_GT(c.sectionMm, 0);
      EXPECT_LE(c.sectionMm, 40) << "a narrow section";
    }
  }
  auto bad = canonicalGrasps("wheel");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("unknown part 'wheel'"), std::string::npos);
}

// The lever's arm (x 14..48 mm, 10 mm wide) between a hub of radius 14 at x = 0 (18 mm high)
// and one of radius 8 at x = 56 (10 mm high), with a 5 mm high lug at x 24..32 on its +y
// side: the jaws (5 mm thick, 10 mm long, 2 mm off the arm) reach the arm's mid-height
// (4 mm) only where they touch none of them: centres x = 18 and 38..46 (samples 2, 12..16).
TEST(grasp_truth, JawsThatWouldTouchTheHubsOrTheLugLeaveNoTruth) {
  const DepthScene s = leverScene();
  auto t = sceneGraspTruth(s, "lever");
  ASSERT_TRUE(t) << t.error().message;
  const auto got = samples(*t);
  for (int k : {12, 13, 14, 15, 16}) EXPECT_TRUE(got.count(k)) << "sample " << k << " (x = " << 14 + 2 * k << " mm) is free";
  for (int k : {0, 1, 3, 4, 5, 6, 7, 8, 9, 10, 11, 17}) EXPECT_FALSE(got.count(k)) << "sample " << k << " (x = " << 14 + 2 * k << " mm)";
  for (const auto& g : *t) {
    const double x = 14 + 2.0 * g.sample, z = 556;
    EXPECT_EQ(g.grasp, "arm");
    EXPECT_EQ(g.part, 0);
    EXPECT_NEAR(g.u, 800 * x / z + 319.5, 1e-6);
    EXPECT_NEAR(g.v, 239.5, 1e-6);
    EXPECT_NEAR(g.angleDeg, 90, 1e-6) << "the closing axis (model y) runs up the image";
    EXPECT_NEAR(g.widthMm, 14, 1e-9);
    EXPECT_NEAR(g.widthPx, 14 * 800 / z, 1e-6);
    EXPECT_NEAR(g.jawPx, 10 * 800 / z, 1e-6);
    EXPECT_NEAR(g.centreCam.z, z, 1e-6);
  }
}

// A housing standing on its end (model x up, the lug's end x = -38 on the floor): the top
// face is the block's 36 x 22 mm end; across its 22 mm height (model z) the 10 mm jaws fit
// anywhere along its 36 mm (model y in -13..13), so a grasp in the middle of that face is as
// true as one 9 mm off it. The truth once held the lines y = +-9 only, and the metric (a
// match with any true rectangle) called the middle, 9 mm from either along a 10 mm jaw,
// a miss. Centre x = 20 (5 mm below the top: the boss at x 1..19 stands in the +z jaw's way
// deeper down).
TEST(grasp_truth, AHousingOnItsEndIsGraspedAcrossItsHeightAnywhereAlongTheFace) {
  Eigen::Isometry3d binFromModel = Eigen::Isometry3d::Identity();
  binFromModel.linear() = Eigen::AngleAxisd(-M_PI / 2, V3::UnitY()).toRotationMatrix();  // model x -> bin z
  binFromModel.translation() = V3(0, 0, 38);
  ASSERT_NEAR((binFromModel.linear() * V3::UnitX() - V3::UnitZ()).norm(), 0, 1e-12);
  const DepthScene s = partScene("housing", binFromModel);
  auto t = sceneGraspTruth(s, "housing");
  ASSERT_TRUE(t) << t.error().message;
  Eigen::Isometry3d camFromBin = Eigen::Isometry3d::Identity();
  camFromBin.linear() = V3(1, -1, -1).asDiagonal();
  camFromBin.translation() = V3(0, 0, 560);
  for (double y : {-12.0, -8.0, -4.0, 0.0, 4.0, 8.0, 12.0}) {
    const V3 c = camFromBin * binFromModel * V3(20, y, 11);
    int found = 0;
    for (const auto& g : *t) {
      // (at y = 0 the grasp across the 36 mm width shares the centre)
      if ((V3(g.centreCam.x, g.centreCam.y, g.centreCam.z) - c).norm() < 1e-6 && std::abs(g.widthMm - 26) < 1e-9) {
        ++found;
        EXPECT_NEAR(g.angleDeg, 0, 1e-6) << "model z (bin -x after the turn) runs along the image's rows";
      }
    }
    EXPECT_EQ(found, 1) << "a true centre across the 22 mm height (26 mm opening) at model y = " << y << " mm";
  }
}

TEST(grasp_truth, AnObstacleBesideAJawRemovesThoseCentres) {
  // A 20 mm block where the -y jaw of centres x 36..48 would go.
  const DepthScene s = leverScene(0, 0, {box({40, -14, 0}, {44, -8, 20})});
  auto t = sceneGraspTruth(s, "lever");
  ASSERT_TRUE(t);
  const auto got = samples(*t);
  for (int k : {12, 13, 14, 15, 16}) EXPECT_FALSE(got.count(k)) << "sample " << k;
}

TEST(grasp_truth, AClosingAxisTiltedMoreThan20DegreesFromTheImagePlaneIsNoGrasp) {
  auto flat = sceneGraspTruth(leverScene(15, 20), "lever");
  ASSERT_TRUE(flat);
  EXPECT_FALSE(flat->empty()) << "15 deg is within the bound";
  auto tilted = sceneGraspTruth(leverScene(25, 20), "lever");
  ASSERT_TRUE(tilted);
  EXPECT_TRUE(tilted->empty());
}

TEST(grasp_truth, RenderedScenesGiveTruthOnTheVisiblePart) {
  for (const auto& name : depthPartNames()) {
    DepthSceneOptions o;
    o.part = name;
    o.partsPerScene = 2;
    int withTruth = 0;
    for (std::uint64_t i = 0; i < 6; ++i) {
      auto s = renderDepthScene(o, i);
      ASSERT_TRUE(s);
      auto t = sceneGraspTruth(*s, name);
      ASSERT_TRUE(t) << t.error().message;
      withTruth += !t->empty();
      for (const auto& g : *t) {
        // the centre pixel shows the part, the rectangle projects from the camera-frame centre
        const int u = static_cast<int>(std::lround(g.u)), v = static_cast<int>(std::lround(g.v));
        EXPECT_EQ(s->labels.at<std::uint16_t>(v, u), g.part + 1);
        EXPECT_NEAR(g.u, s->camera.fx * g.centreCam.x / g.centreCam.z + s->camera.cx, 1e-6);
        EXPECT_GT(g.angleDeg, -90);
        EXPECT_LE(g.angleDeg, 90);
        EXPECT_NEAR(g.widthPx, g.widthMm * s->camera.fx / g.centreCam.z, 0.02 * g.widthPx);
      }
    }
    EXPECT_GE(withTruth, 3) << name;
  }
  DepthScene noExact;
  EXPECT_FALSE(sceneGraspTruth(noExact, "lever"));
}

std::string tempFile(const std::string& name, const std::string& text) {
  const auto p = std::filesystem::temp_directory_path() / (name + "-" + std::to_string(::getpid()));
  std::ofstream(p) << text;
  return p.string();
}

TEST(grasp_truth_file, RoundTripsAndNamesFileAndLineOnError) {
  vgr::config::GraspTruthRow r;
  r.image = "images/0000.png";
  r.hasGrasp = true;
  r.part = 1, r.grasp = "arm", r.sample = 7;
  r.u = 320.25, r.v = 200.5, r.angleDeg = -45.5, r.widthPx = 20.125, r.jawPx = 14.375;
  r.xMm = 10.5, r.yMm = -3.25, r.zMm = 556, r.widthMm = 14;
  vgr::config::GraspTruthRow empty;
  empty.image = "images/0001.png";
  const std::string head = vgr::config::graspTruthCsvHeader() + "\n";
  const std::string path = tempFile("grasps.csv", head + graspTruthCsvRow(r) + "\n" + graspTruthCsvRow(empty) + "\n");
  auto rows = vgr::config::loadGraspTruth(path);
  ASSERT_TRUE(rows) << rows.error().message;
  ASSERT_EQ(rows->size(), 2u);
  const auto& a = (*rows)[0];
  EXPECT_TRUE(a.hasGrasp);
  EXPECT_EQ(a.grasp, "arm");
  EXPECT_EQ(a.part, 1);
  EXPECT_EQ(a.sample, 7);
  EXPECT_DOUBLE_EQ(a.u, 320.25);
  EXPECT_DOUBLE_EQ(a.angleDeg, -45.5);
  EXPECT_DOUBLE_EQ(a.zMm, 556);
  EXPECT_EQ(a.line, 2);
  EXPECT_FALSE((*rows)[1].hasGrasp);
  std::filesystem::remove(path);

  struct Bad {
    std::string text, want;
  };
  const Bad bad[] = {
      {"image,part\n", ":1: the header must be"},
      {head + "images/0000.png,0,arm,0,1,2,95,20,14,0,0,556,14\n", ":2: column 'angle_deg': 95 is outside (-90, 90]"},
      {head + "images/0000.png,0,arm,0,x,2,5,20,14,0,0,556,14\n", ":2: column 'u_px': expected a number, got 'x'"},
      {head + "images/0000.png,-1,arm,0,1,2,5,20,14,0,0,556,14\n", ":2: column 'part': expected an integer >= 0"},
      {head + "images/0000.png,0,arm,0,1,2,5,0,14,0,0,556,14\n", ":2: width_px, jaw_px, z_mm and width_mm must be > 0"},
      {head + "images/0000.png,0,arm,0,1,2,5,20,14,0,0,556\n", ":2: expected 13 fields, got 12"},
      {head + "images/0000.png,,,,,,,,,,,,\nimages/0000.png,0,arm,0,1,2,5,20,14,0,0,556,14\n",
       ":3: image 'images/0000.png' has both an empty row and grasp rows"},
      {head, ": no rows after the header"},
  };
  for (const auto& b : bad) {
    const std::string p = tempFile("grasps-bad.csv", b.text);
    auto got = vgr::config::loadGraspTruth(p);
    ASSERT_FALSE(got) << b.text;
    EXPECT_EQ(got.error().message.rfind(p, 0), 0u) << got.error().message;
    EXPECT_NE(got.error().message.find(b.want), std::string::npos) << got.error().message;
    EXPECT_EQ(got.error().message.find('\n'), std::string::npos);
    std::filesystem::remove(p);
  }
}

}  // namespace
