// Model building from depth views (paper 004 Sec. 3.1; issue 13): 12 rendered views of a
// part on a table with robot-pose noise +-1 mm / +-0.5 deg give a model within 0.3 mm
// (mean) of the part's true surface; with one view's reported position 20 mm off, the
// report names that view's edges as rejected and the model still meets the bar; bad input
// is refused with a line naming the view or parameter.
#include <gtest/gtest.h>

#include <cstdio>
#include <map>
#include <string>
#include <vector>

#include "sim/depth_parts.hpp"
#include "sim/depth_scene.hpp"
#include "vision/cloud/model_builder.hpp"
#include "vision/depth_image.hpp"

namespace vgr::vision::cloud {
namespace {

// The 12 views of a part (rendered once per part for all tests): depth + reported pose
// with the robot's noise (+-1 mm / +-0.5 deg, the sim's defaults).
const std::vector<ModelView>& viewsOf(const std::string& partName) {
  static std::map<std::string, std::vector<ModelView>> cache;
  auto& views = cache[partName];
  if (!views.empty()) return views;
  sim::PartViewsOptions o;
  o.part = partName;
  o.views = 12;
  o.poseNoiseMm = 1;
  o.poseNoiseDeg = 0.5;
  o.seed = 3;
  auto rendered = sim::renderPartViews(o);
  EXPECT_TRUE(rendered) << rendered.error().message;
  if (!rendered) return views;
  for (std::size_t i = 0; i < rendered->size(); ++i) {
    const auto& r = (*rendered)[i];
    ModelView v;
    v.name = "view_" + std::to_string(i);
    auto mm = vision::depthToMillimetres(r.depth, o.camera.depthScaleMm, v.name);
    EXPECT_TRUE(mm) << mm.error().message;
    if (!mm) return views;
    v.depthMm = *mm;
    v.intrinsics = {o.camera.fx, o.camera.fy, o.camera.cx, o.camera.cy, o.camera.width, o.camera.height};
    v.reported = r.reported;
    views.push_back(v);
  }
  return views;
}

PlyMesh trueSurface(const std::string& partName) {
  auto part = sim::depthPart(partName);
  EXPECT_TRUE(part);
  const sim::TriMesh m = sim::exteriorMesh(*part, 0.5);
  return {m.vertices, m.triangles};
}

void printReport(const ModelBuildResult& r, const MeshDistance& d) {
  for (const auto& v : r.views)
    std::printf("  %s: %d points, used %d, pose disagreement %.2f mm, fitness %.3f, rmse %.3f mm %s\n", v.name.c_str(),
                v.points, v.used ? 1 : 0, v.poseDisagreementMm, v.fitness, v.rmseMm, v.why.c_str());
  int kept = 0;
  for (const auto& e : r.edges) kept += e.kept ? 1 : 0;
  std::printf("  edges kept %d of %zu; model %zu points; to the true surface: mean %.3f mm, p95 %.3f mm, max %.3f mm\n",
              kept, r.edges.size(), r.model.points.size(), d.meanMm, d.p95Mm, d.maxMm);
}

class ModelOfEachPart : public ::testing::TestWithParam<std::string> {};

TEST_P(ModelOfEachPart, TwelveNoisyViewsGiveAModelWithinAThirdOfAMillimetre) {
  const auto& views = viewsOf(GetParam());
  ASSERT_EQ(views.size(), 12u);
  auto built = buildModel(views, ModelBuildParams{});
  ASSERT_TRUE(built) << built.error().message;
  auto d = modelToMeshDistance(built->model, trueSurface(GetParam()));
  ASSERT_TRUE(d) << d.error().message;
  printReport(*built, *d);
  // Bracket and housing keep all 12 views; the lever 10: the registration puts two of its
  // views (8, 9: mostly its flat top, seen from the high elevation) 14-17 mm from where
  // they were reported, over the 10 mm bar, and the model is better without them (mean
  // 0.17 mm; with them, ICP started at 6 mm instead of 12: 0.33 mm).
  EXPECT_GE(built->viewsUsed, 10);
  EXPECT_LE(d->meanMm, 0.3);
  EXPECT_GT(built->model.points.size(), 2000u);
  EXPECT_GT(built->bottomPoints, 500);  // closed: the part's footprint on the table, ~1 point per mm^2
  ASSERT_EQ(built->model.normals.size(), built->model.points.size());
}

INSTANTIATE_TEST_SUITE_P(Parts, ModelOfEachPart, ::testing::Values("bracket", "housing", "lever"));

TEST(ModelBuilder, AViewTwentyMillimetresOffIsNamedAndLeftOut) {
  const int bad = 5;
  auto views = viewsOf("bracket");
  ASSERT_EQ(views.size(), 12u);
  // As the sim's bad view: the reported position 20 mm off (here along (0.6, -0.8, 0)).
  views[bad].reported.x += 12;
  views[bad].reported.y -= 16;
  auto built = buildModel(views, ModelBuildParams{});
  ASSERT_TRUE(built) << built.error().message;
  auto d = modelToMeshDistance(built->model, trueSurface("bracket"));
  ASSERT_TRUE(d) << d.error().message;
  printReport(*built, *d);
  EXPECT_FALSE(built->views[bad].used);
  EXPECT_NE(built->views[bad].why.find("reported pose"), std::string::npos) << built->views[bad].why;
  int namedEdges = 0;
  for (const auto& e : built->edges) {
    if (e.source == bad || e.target == bad) {
      EXPECT_FALSE(e.kept);
      if (e.why.find("view_5's reported pose") != std::string::npos) ++namedEdges;
    }
  }
  EXPECT_GT(namedEdges, 0);
  EXPECT_EQ(built->viewsUsed, 11);
  EXPECT_LE(d->meanMm, 0.3);
}

TEST(ModelBuilder, RefusesBadInput) {
  auto views = viewsOf("bracket");
  ASSERT_EQ(views.size(), 12u);
  ModelBuildParams p;
  p.icpFinalMm = 20;  // > icp_start_mm
  auto r = buildModel(views, p);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("icp_final_mm"), std::string::npos) << r.error().message;

  std::vector<ModelView> two(views.begin(), views.begin() + 2);
  r = buildModel(two, ModelBuildParams{});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("at least 3"), std::string::npos) << r.error().message;

  auto wrongSize = views;
  wrongSize[4].intrinsics.width = 320;
  r = buildModel(wrongSize, ModelBuildParams{});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("view_4"), std::string::npos) << r.error().message;

  auto empty = views;
  empty[2].depthMm = cv::Mat(views[2].depthMm.size(), CV_32FC1, cv::Scalar(0));  // a new buffer: the views are shared
  r = buildModel(empty, ModelBuildParams{});
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("view_2"), std::string::npos) << r.error().message;

  EXPECT_FALSE(modelToMeshDistance(PlyCloud{}, trueSurface("bracket")));
}

}  // namespace
}  // namespace vgr::vision::cloud
