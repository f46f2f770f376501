// The dataset renderer (sim/part_scene.hpp): truth geometry (projection difference of raised
// features, paper 000), the template's consistency with the scenes, placement rules.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "sim/part_scene.hpp"

namespace {

using namespace vgr::sim;

PartSceneOptions small() {
  PartSceneOptions o;
  o.width = 640;
  o.height = 512;
  o.focalPx = 1000;
  o.seed = 3;
  return o;
}

TEST(locate_scene, RaisedGraspPointShiftsRadiallyAwayFromTheCentre) {
  const PartSceneRenderer r(PartModel::multi(3), small());
  const PartModel& m = r.part();
  ASSERT_EQ(m.graspHeightMm, 35.0);
  const PlacedPart p = r.place(60, -40, 30);
  // The same grasp point on the belt plane (height 0) projects closer to the image centre:
  // pinhole shift r * h / (Z - h) (paper 000, Fig. 1).
  const double c = std::cos(30 * M_PI / 180), s = std::sin(30 * M_PI / 180);
  const double gx = 60 + c * m.grasp.x - s * m.grasp.y, gy = -40 + s * m.grasp.x + c * m.grasp.y;
  const auto flat = r.camera().project({gx, gy, 0});
  ASSERT_TRUE(flat);
  const double cu = (640 - 1) / 2.0, cv = (512 - 1) / 2.0;
  const double r0 = std::hypot(flat->u - cu, flat->v - cv), r1 = std::hypot(p.uPx - cu, p.vPx - cv);
  EXPECT_NEAR(r1 / r0, 500.0 / (500.0 - 35.0), 1e-9);
  EXPECT_NEAR(p.angleDeg, 30.0, 1e-9);  // a camera parallel to the belt keeps angles
}

TEST(locate_scene, TemplateIsTheNoiseFreeSceneAtTheTaughtPose) {
  PartSceneOptions o = small();
  const PartSceneRenderer r(PartModel::multi(4), o);
  cv::Mat templ, img;
  const PartTemplate t = r.renderTemplate(templ);
  PartScene s;
  s.parts.push_back(r.place(0, 0, 0));
  r.render(s, img);
  const cv::Mat crop = img(cv::Rect(t.offsetX, t.offsetY, templ.cols, templ.rows));
  EXPECT_EQ(cv::norm(crop, templ, cv::NORM_INF), 0.0);
  EXPECT_NEAR(t.graspU + t.offsetX, s.parts[0].uPx, 1e-9);
  EXPECT_NEAR(t.graspV + t.offsetY, s.parts[0].vPx, 1e-9);
  ASSERT_EQ(t.regions.size(), 4u);  // one top face per level
  EXPECT_EQ(t.regions.back().heightMm, 50.0);
}

TEST(locate_scene, PartsStayInsideAndApartAndEmptyImagesHaveNone) {
  PartSceneOptions o = small();
  o.width = 1280;
  o.height = 1024;
  o.partsPerImage = 3;
  o.angleRangeDeg = 180;
  const PartSceneRenderer r(PartModel::flat(), o);
  for (std::uint64_t i = 0; i < 20; ++i) {
    const PartScene s = r.sample(i);
    ASSERT_EQ(s.parts.size(), 3u) << i;
    for (std::size_t a = 0; a < 3; ++a) {
      EXPECT_GT(s.parts[a].uPx, 0);
      EXPECT_LT(s.parts[a].uPx, 1279);
      for (std::size_t b = a + 1; b < 3; ++b)  // flat part: 100 mm long = 200 px at the grasp, 40 px off centre
        EXPECT_GT(std::hypot(s.parts[a].uPx - s.parts[b].uPx, s.parts[a].vPx - s.parts[b].vPx), 100) << i;
    }
    EXPECT_EQ(r.sample(i).parts[0].uPx, s.parts[0].uPx);  // deterministic
  }
  o.emptyRatio = 1;
  const PartSceneRenderer e(PartModel::flat(), o);
  EXPECT_TRUE(e.sample(5).parts.empty());
}

TEST(locate_scene, LightingGradientHasTheRequestedRatio) {
  PartSceneOptions o = small();
  o.illumRatio = 2;
  o.background = 100;
  o.emptyRatio = 1;
  const PartSceneRenderer r(PartModel::flat(), o);
  cv::Mat img;
  r.render(r.sample(0), img);
  double lo = 0, hi = 0;
  cv::minMaxLoc(img, &lo, &hi);
  EXPECT_NEAR(hi / lo, 2.0, 0.05);
}

// Decoys (pieces of the part's own faces, docs/datasets.md) land only off the parts, change
// nothing else, and are deterministic in the seed.
TEST(locate_scene, DecoysLieOffThePartsAndAreDeterministic) {
  PartSceneOptions o = small();
  o.width = 1280;
  o.height = 1024;
  o.partsPerImage = 2;
  const PartSceneRenderer plain(PartModel::multi(3), o);
  o.decoys = 6;
  const PartSceneRenderer decoy(PartModel::multi(3), o);
  for (std::uint64_t i = 0; i < 4; ++i) {
    const PartScene s = decoy.sample(i);
    ASSERT_FALSE(s.parts.empty());
    EXPECT_EQ(plain.sample(i).parts.size(), s.parts.size());  // the poses do not depend on decoys
    cv::Mat a, b, again;
    plain.render(s, a);
    decoy.render(s, b);
    decoy.render(s, again);
    EXPECT_EQ(cv::norm(b, again, cv::NORM_INF), 0.0) << i;
    cv::Mat changed = a != b;
    // Decoys cover some of the belt: at least a piece 0.2 part radii across (~20 px) in all.
    EXPECT_GT(cv::countNonZero(changed), 400) << i;
    // ... but never a pixel of a part's footprint (its top faces through the camera).
    for (const auto& p : s.parts) {
      const auto g = decoy.camera().project({p.xMm, p.yMm, 0});
      ASSERT_TRUE(g);
      const double rPx = decoy.part().radiusMm * decoy.focalPx() / (o.cameraHeightMm - 50);
      cv::Mat disc = cv::Mat::zeros(changed.size(), CV_8UC1);
      cv::circle(disc, cv::Point(cvRound(g->u), cvRound(g->v)), static_cast<int>(rPx * 0.5), cv::Scalar(255), cv::FILLED);
      cv::Mat inside;
      cv::bitwise_and(changed, disc, inside);
      EXPECT_EQ(cv::countNonZero(inside), 0) << "image " << i;
    }
  }
}

}  // namespace
