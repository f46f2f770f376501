// Method "shape" (vision/locate/shape_matcher.hpp) on rendered 1280x1024 scenes (part ~150 px
// long, noise sigma 5): sub-pixel accuracy against the renderer's truth at any angle, angle
// range and ROI, 30 % occlusion, a 2:1 illumination gradient, no part, three parts, inverted
// contrast and bad parameters. Speed is measured by vgr-bench-locate, not here.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/angles.hpp"
#include "sim/locate_scenes.hpp"
#include "vision/locate/locator.hpp"

namespace {

using vgr::normaliseDeg;
using vgr::sim::SceneTruth;

constexpr int kW = 1280, kH = 1024;
constexpr double kSigma = 5;
// SceneRenderer draws the part up to ~0.06 px away from its SceneTruth (8x supersampled
// fillPoly; measured in docs/performance.md): the tolerances below include that.
constexpr double kPosTolPx = 0.2;
constexpr double kAngTolDeg = 0.1;

struct Fixture {
  vgr::sim::SceneRenderer renderer = vgr::sim::makeRenderer(kW, kH, 1200, 800, kSigma, 3);  // 1.5 px/mm
  vgr::sim::SceneTemplate tp = vgr::sim::makeSceneTemplate(renderer, 0.0, 12, 99);
  // Grasp point 30 px along the part's axis from its centroid (toward the tip): it must turn
  // with the part.
  vgr::vision::TaughtTemplate taught() const {
    vgr::vision::TaughtTemplate t;
    t.grasp = {tp.grasp.u + 30, tp.grasp.v};
    return t;
  }
  vgr::vision::PixelPoint expectedGrasp(const SceneTruth& t) const {
    const double a = (t.angleImgDeg - tp.truth.angleImgDeg) * std::numbers::pi / 180;
    return {t.uPx + 30 * std::cos(a), t.vPx - 30 * std::sin(a)};
  }
  double expectedAngle(const SceneTruth& t) const { return normaliseDeg(t.angleImgDeg - tp.truth.angleImgDeg); }
};

std::unique_ptr<vgr::vision::Locator> make(const Fixture& f, const vgr::vision::TaughtTemplate& t) {
  auto loc = vgr::vision::makeLocator("shape", f.tp.image, t);
  EXPECT_TRUE(loc.has_value()) << loc.error().message;
  return loc ? std::move(*loc) : nullptr;
}

void expectPose(const Fixture& f, const vgr::vision::Detection& d, const SceneTruth& t, double posTol, double angTol) {
  const auto g = f.expectedGrasp(t);
  EXPECT_LT(std::hypot(d.u - g.u, d.v - g.v), posTol) << "at (" << t.uPx << ", " << t.vPx << ") " << t.angleImgDeg << " deg";
  EXPECT_LT(std::abs(normaliseDeg(d.angleDeg - f.expectedAngle(t))), angTol) << "at " << t.angleImgDeg << " deg";
}

TEST(shape_matcher, FindsThePartAtAnyAngleToSubPixelAccuracy) {
  Fixture f;
  auto loc = make(f, f.taught());
  ASSERT_TRUE(loc);
  EXPECT_EQ(loc->method(), "shape");
  cv::Mat img;
  const double poses[][3] = {{300.2, 260.7, 0.0},    {900.6, 700.3, 37.3},  {640.0, 512.0, 90.0},   {210.4, 800.9, 179.6},
                             {1050.3, 230.1, -45.2}, {500.5, 600.5, -123.4}, {777.7, 333.3, 12.34}, {400.1, 420.9, -179.9}};
  for (std::size_t i = 0; i < std::size(poses); ++i) {
    const auto t = vgr::sim::truthAt(f.renderer, poses[i][0], poses[i][1], f.tp.truth.angleImgDeg + poses[i][2]);
    f.renderer.renderTruth(t, 1000 + i, img);
    auto out = loc->locate(img);
    ASSERT_TRUE(out.has_value()) << out.error().message;
    ASSERT_EQ(out->parts.size(), 1u) << "pose " << i;
    expectPose(f, out->parts.front(), t, kPosTolPx, kAngTolDeg);
    EXPECT_GT(out->parts.front().score, 0.8);
  }
}

TEST(shape_matcher, AngleRangeAndRoiLimitTheSearch) {
  Fixture f;
  auto taught = f.taught();
  taught.angleMinDeg = -60, taught.angleMaxDeg = 60;
  auto loc = make(f, taught);
  ASSERT_TRUE(loc);
  cv::Mat img;
  auto t = vgr::sim::truthAt(f.renderer, 640.3, 500.8, f.tp.truth.angleImgDeg + 41.0);
  f.renderer.renderTruth(t, 7, img);
  auto out = loc->locate(img);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->parts.size(), 1u);
  expectPose(f, out->parts.front(), t, kPosTolPx, kAngTolDeg);

  t = vgr::sim::truthAt(f.renderer, 640.3, 500.8, f.tp.truth.angleImgDeg + 100.0);
  f.renderer.renderTruth(t, 8, img);
  out = loc->locate(img);
  ASSERT_TRUE(out.has_value());
  EXPECT_TRUE(out->parts.empty()) << "a part at 100 deg is outside [-60, 60]";

  // ROI: the part at (900, 700) is found in a ROI around it (full-image coordinates), not in
  // one elsewhere.
  auto inRoi = f.taught();
  inRoi.searchRoi = {650, 450, 500, 500};
  auto locIn = make(f, inRoi);
  auto outRoi = f.taught();
  outRoi.searchRoi = {0, 0, 600, 500};
  auto locOut = make(f, outRoi);
  t = vgr::sim::truthAt(f.renderer, 900.4, 700.6, f.tp.truth.angleImgDeg - 70.0);
  f.renderer.renderTruth(t, 9, img);
  out = locIn->locate(img);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->parts.size(), 1u);
  expectPose(f, out->parts.front(), t, kPosTolPx, kAngTolDeg);
  out = locOut->locate(img);
  ASSERT_TRUE(out.has_value());
  EXPECT_TRUE(out->parts.empty());
}

TEST(shape_matcher, FindsThePartWithAThirdOfItsOutlineOccluded) {
  Fixture f;
  auto loc = make(f, f.taught());
  cv::Mat img;
  // Part axis horizontal (angle 0), 1.5 px/mm: its outline is 75 (back) + 2 x 120 (sides) +
  // 2 x 48 (tip) = 411 px long and reaches 68 px behind the centroid. A belt-coloured block
  // over the back end, x < centroid - 44 px, hides the back edge and 24 px of each side:
  // 123 px, 30 % of the outline.
  const auto t = vgr::sim::truthAt(f.renderer, 600.4, 480.3, f.tp.truth.angleImgDeg + 0.0);
  f.renderer.renderTruth(t, 11, img);
  cv::rectangle(img, cv::Rect(static_cast<int>(std::lround(t.uPx)) - 44 - 100, static_cast<int>(t.vPx) - 60, 100, 120),
                cv::Scalar(32), cv::FILLED);
  auto out = loc->locate(img);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->parts.size(), 1u);
  expectPose(f, out->parts.front(), t, 0.3, 0.15);
  EXPECT_LT(out->parts.front().score, 0.8) << "the occluded part should score lower";
}

TEST(shape_matcher, FindsThePartUnderA2To1IlluminationGradient) {
  Fixture f;
  auto loc = make(f, f.taught());
  cv::Mat img, lit;
  const auto t = vgr::sim::truthAt(f.renderer, 700.2, 400.7, f.tp.truth.angleImgDeg + 63.0);
  f.renderer.renderTruth(t, 12, img);
  // Brightness falls linearly from 1 at the left to 0.5 at the right.
  cv::Mat gain(img.size(), CV_32F);
  for (int x = 0; x < img.cols; ++x) gain.col(x).setTo(1.0 - 0.5 * x / (img.cols - 1));
  img.convertTo(lit, CV_32F);
  lit = lit.mul(gain);
  lit.convertTo(img, CV_8U);
  auto out = loc->locate(img);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->parts.size(), 1u);
  expectPose(f, out->parts.front(), t, kPosTolPx, kAngTolDeg);
}

TEST(shape_matcher, NoPartGivesNothingAndThreePartsGiveThree) {
  Fixture f;
  auto taught = f.taught();
  taught.maxParts = 5;
  auto loc = make(f, taught);
  // Empty belt (the renderer with the part far outside the image).
  cv::Mat img;
  auto away = vgr::sim::truthAt(f.renderer, 640, 512, 0);
  away.xMm += 5000;
  f.renderer.renderTruth(away, 13, img);
  auto out = loc->locate(img);
  ASSERT_TRUE(out.has_value());
  EXPECT_TRUE(out->parts.empty()) << "best score " << out->parts.front().score;

  // Three parts: noise-free renderings combined (max), then sigma 5 noise.
  auto cleanOpts = f.renderer.options();
  cleanOpts.noiseSigma = 0;
  const vgr::sim::SceneRenderer clean(f.renderer.model(), cleanOpts);
  const SceneTruth truths[] = {vgr::sim::truthAt(clean, 250.3, 250.6, 20.0), vgr::sim::truthAt(clean, 900.8, 300.2, -100.0),
                               vgr::sim::truthAt(clean, 640.5, 760.4, 170.0)};
  cv::Mat one;
  img.setTo(0);
  for (const auto& t : truths) {
    clean.renderTruth(t, 0, one);
    img = cv::max(img, one);
  }
  cv::Mat noise(img.size(), CV_16S), sum;
  cv::randn(noise, 0, kSigma);
  img.convertTo(sum, CV_16S);
  sum += noise;
  sum.convertTo(img, CV_8U);
  out = loc->locate(img);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->parts.size(), 3u);
  for (const auto& t : truths) {
    const auto g = f.expectedGrasp(t);
    int hits = 0;
    for (const auto& d : out->parts)
      if (std::hypot(d.u - g.u, d.v - g.v) < kPosTolPx && std::abs(normaliseDeg(d.angleDeg - f.expectedAngle(t))) < kAngTolDeg) ++hits;
    EXPECT_EQ(hits, 1) << "part at (" << t.uPx << ", " << t.vPx << ")";
  }
}

TEST(shape_matcher, PolarityUseRejectsInvertedContrastIgnoreGlobalFindsIt) {
  Fixture f;
  cv::Mat img;
  const auto t = vgr::sim::truthAt(f.renderer, 500.5, 500.5, f.tp.truth.angleImgDeg - 20.0);
  f.renderer.renderTruth(t, 14, img);
  img = 255 - img;
  auto use = make(f, f.taught());
  auto out = use->locate(img);
  ASSERT_TRUE(out.has_value());
  EXPECT_TRUE(out->parts.empty());
  auto taught = f.taught();
  taught.params["polarity"] = "ignore_global";
  auto ignore = make(f, taught);
  out = ignore->locate(img);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->parts.size(), 1u);
  expectPose(f, out->parts.front(), t, kPosTolPx, kAngTolDeg);
}

TEST(shape_matcher, BadParametersAreNamed) {
  Fixture f;
  auto expectError = [&](const std::string& name, const std::string& value, const std::string& needle) {
    auto taught = f.taught();
    taught.params[name] = value;
    auto loc = vgr::vision::makeLocator("shape", f.tp.image, taught);
    ASSERT_FALSE(loc.has_value()) << name << "=" << value;
    EXPECT_EQ(loc.error().code, vgr::Status::BadArgument);
    EXPECT_NE(loc.error().message.find(needle), std::string::npos) << loc.error().message;
  };
  expectError("greediness", "2", "shape: parameter 'greediness'");
  expectError("levels", "x", "parameter 'levels'");
  expectError("polarity", "both", "parameter 'polarity'");
  expectError("max_ponts", "100", "unknown parameter 'max_ponts'");
  expectError("model_contrast", "250", "model_contrast");  // no template edge that strong
  cv::Mat flat(100, 100, CV_8UC1, cv::Scalar(40));
  auto loc = vgr::vision::makeLocator("shape", flat, f.taught());
  ASSERT_FALSE(loc.has_value());
  EXPECT_NE(loc.error().message.find("edge points"), std::string::npos) << loc.error().message;
}

}  // namespace
