// Methods "hu" and "sift" (paper 002) on rendered scenes (sim/part_scene.hpp): the grasp point
// and rotation within tolerance of the renderer's truth, nothing on images without the part,
// and the right count on images with three parts. Small images keep SIFT fast.
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "sim/part_scene.hpp"
#include "vision/locate/locator.hpp"

namespace {

using vgr::sim::PartModel;
using vgr::sim::PartScene;
using vgr::sim::PartSceneOptions;
using vgr::sim::PartSceneRenderer;

PartSceneRenderer flatScenes(int parts, double emptyRatio, int clutter) {
  PartSceneOptions o;
  o.width = 800;
  o.height = 640;
  o.focalPx = 1000;  // 2 px/mm on the belt, as in the sim cell
  o.angleRangeDeg = 180;
  o.noiseSigma = 3;
  o.partsPerImage = parts;
  o.emptyRatio = emptyRatio;
  o.clutter = clutter;
  o.seed = 7;
  return PartSceneRenderer(PartModel::flat(), o);
}

std::unique_ptr<vgr::vision::Locator> build(const std::string& method, const PartSceneRenderer& r, int maxParts) {
  cv::Mat templ;
  const auto t = r.renderTemplate(templ);
  vgr::vision::TaughtTemplate taught;
  taught.grasp = {t.graspU, t.graspV};
  taught.maxParts = maxParts;
  auto loc = vgr::vision::makeLocator(method, templ, taught);
  EXPECT_TRUE(loc.has_value()) << (loc ? "" : loc.error().message);
  return loc ? std::move(*loc) : nullptr;
}

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

class locate_methods : public ::testing::TestWithParam<std::string> {};

// Tolerances: paper 000's success thresholds are 4 px / 0.5 deg; on a flat part both
// methods do far better (measured with vgr eval: hu 0.29 px / 0.07 deg, sift 0.85 px /
// 0.31 deg max), so the bounds here are 1.5 px and 0.5 deg.
TEST_P(locate_methods, FindsAFlatPartAnywhereAtAnyRotation) {
  const auto r = flatScenes(1, 0, 3);
  auto loc = build(GetParam(), r, 1);
  ASSERT_TRUE(loc);
  cv::Mat img;
  for (std::uint64_t i = 0; i < 3; ++i) {
    const PartScene s = r.sample(i);
    ASSERT_EQ(s.parts.size(), 1u);
    r.render(s, img);
    auto out = loc->locate(img);
    ASSERT_TRUE(out.has_value()) << out.error().message;
    ASSERT_EQ(out->parts.size(), 1u) << "image " << i;
    const auto& d = out->parts.front();
    const auto& t = s.parts.front();
    EXPECT_LT(std::hypot(d.u - t.uPx, d.v - t.vPx), 1.5) << "image " << i;
    EXPECT_LT(angleDiff(d.angleDeg, t.angleDeg), 0.5) << "image " << i << ": " << d.angleDeg << " vs " << t.angleDeg;
    EXPECT_GE(d.score, 0.5);
    EXPECT_LE(d.score, 1.0);
  }
}

TEST_P(locate_methods, FindsNothingWithoutThePart) {
  const auto r = flatScenes(1, 1.0, 8);  // every image empty, clutter only
  auto loc = build(GetParam(), r, 4);
  ASSERT_TRUE(loc);
  cv::Mat img;
  for (std::uint64_t i = 0; i < 3; ++i) {
    const PartScene s = r.sample(i);
    ASSERT_TRUE(s.parts.empty());
    r.render(s, img);
    auto out = loc->locate(img);
    ASSERT_TRUE(out.has_value()) << out.error().message;
    EXPECT_TRUE(out->parts.empty()) << "image " << i << ": " << out->parts.size() << " part(s)";
  }
}

TEST_P(locate_methods, CountsThreeParts) {
  const auto r = flatScenes(3, 0, 0);
  auto loc = build(GetParam(), r, 8);
  ASSERT_TRUE(loc);
  cv::Mat img;
  for (std::uint64_t i = 0; i < 2; ++i) {
    const PartScene s = r.sample(i);
    ASSERT_EQ(s.parts.size(), 3u);
    r.render(s, img);
    auto out = loc->locate(img);
    ASSERT_TRUE(out.has_value()) << out.error().message;
    ASSERT_EQ(out->parts.size(), 3u) << "image " << i;
    // Every truth part has a detection within tolerance.
    for (const auto& t : s.parts) {
      double best = 1e9;
      for (const auto& d : out->parts) best = std::min(best, std::hypot(d.u - t.uPx, d.v - t.vPx));
      EXPECT_LT(best, 1.5);
    }
    for (std::size_t k = 1; k < out->parts.size(); ++k) EXPECT_GE(out->parts[k - 1].score, out->parts[k].score);
  }
}

INSTANTIATE_TEST_SUITE_P(hu_sift, locate_methods, ::testing::Values("hu", "sift"));

TEST(locate_methods_params, BadParametersAreNamed) {
  const auto r = flatScenes(1, 0, 0);
  cv::Mat templ;
  const auto t = r.renderTemplate(templ);
  vgr::vision::TaughtTemplate taught;
  taught.grasp = {t.graspU, t.graspV};
  taught.params["ratio"] = "2";
  auto s = vgr::vision::makeLocator("sift", templ, taught);
  ASSERT_FALSE(s.has_value());
  EXPECT_NE(s.error().message.find("sift: parameter 'ratio'"), std::string::npos) << s.error().message;
  taught.params.clear();
  taught.params["shape_scal"] = "0.1";
  auto h = vgr::vision::makeLocator("hu", templ, taught);
  ASSERT_FALSE(h.has_value());
  EXPECT_NE(h.error().message.find("unknown parameter 'shape_scal'"), std::string::npos) << h.error().message;
}

}  // namespace
