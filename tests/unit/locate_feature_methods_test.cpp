// The feature and contour methods (orb-ransac, orb-prosac, orb-adk: paper 001's Table 1
// methods; contour-weighted: paper 000) against synthetic images with known truth
// (sim/synth_part.hpp): a textured part turned within +-60 degrees, noise
// sigma 5, 1280 x 1024. One parameterised suite: found within tolerance with true matches,
// nothing without the part, three parts, max_parts, and named errors.
#include <cmath>
#include <random>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "sim/synth_part.hpp"
#include "vision/locate/locator.hpp"

namespace {

using vgr::sim::synth::PartPose;

const cv::Size kSize(1280, 1024);

struct Case {
  const char* method;
  double posTolPx, angTolDeg;       // accuracy bars against the synthetic truth
  const char* badParam;             // a parameter of this method set out of range
  const char* badValue;
};

class locate_feature_methods : public ::testing::TestWithParam<Case> {};

struct Fixture {
  vgr::sim::synth::SynthPart part = vgr::sim::synth::makeTexturedPart(false);
  vgr::sim::synth::SynthTemplate templ = vgr::sim::synth::makeTemplate(part);
  vgr::vision::TaughtTemplate taught() const {
    vgr::vision::TaughtTemplate t;
    t.grasp = templ.grasp;
    t.minScore = 0.3;
    return t;
  }
};

TEST_P(locate_feature_methods, FindsThePartWithinTolerance) {
  const Fixture f;
  const Case& c = GetParam();
  auto loc = vgr::vision::makeLocator(c.method, f.templ.image, f.taught());
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  EXPECT_EQ((*loc)->method(), c.method);
  std::mt19937 rng(11);
  double maxPos = 0, maxAng = 0;
  for (int k = 0; k < 4; ++k) {
    const PartPose truth = vgr::sim::synth::randomPose(rng, kSize, 60);
    const cv::Mat img = vgr::sim::synth::renderScene(f.part, {truth}, kSize, 5.0, 100 + k);
    auto out = (*loc)->locate(img);
    ASSERT_TRUE(out.has_value()) << out.error().message;
    ASSERT_EQ(out->parts.size(), 1u) << "image " << k;
    const auto& d = out->parts.front();
    maxPos = std::max(maxPos, std::hypot(d.u - truth.u, d.v - truth.v));
    maxAng = std::max(maxAng, vgr::sim::synth::angleDiffDeg(d.angleDeg, truth.angleDeg));
    EXPECT_GE(d.score, 0.3);
    EXPECT_LE(d.score, 1.0);
    EXPECT_FALSE(out->matches.empty());
    EXPECT_GE(out->candidateMatches, static_cast<int>(out->matches.size()));
    EXPECT_GE(vgr::sim::synth::matchTruePositiveRate(out->matches, truth, f.templ.grasp), 0.95);
  }
  // Well inside paper 000's 4 px / 0.5 deg: a homography from >= 100 ORB matches at sigma 5
  // (1 px / 0.3 deg), contour-weighted's gradient refinement (0.5 px / 0.1 deg).
  EXPECT_LT(maxPos, c.posTolPx);
  EXPECT_LT(maxAng, c.angTolDeg);
  std::printf("max position error %.3f px, max angle error %.3f deg\n", maxPos, maxAng);
}

TEST_P(locate_feature_methods, FindsNothingWithoutThePart) {
  const Fixture f;
  const Case& c = GetParam();
  auto loc = vgr::vision::makeLocator(c.method, f.templ.image, f.taught());
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  for (std::uint64_t seed : {1u, 2u}) {
    auto out = (*loc)->locate(vgr::sim::synth::renderDistractorScene(kSize, 5.0, seed));
    ASSERT_TRUE(out.has_value());
    EXPECT_TRUE(out->parts.empty()) << "seed " << seed << ": score " << out->parts.front().score;
  }
  auto out = (*loc)->locate(cv::Mat(kSize, CV_8U, cv::Scalar(vgr::sim::synth::kBackground)));
  ASSERT_TRUE(out.has_value());
  EXPECT_TRUE(out->parts.empty());
}

TEST_P(locate_feature_methods, FindsThreeParts) {
  const Fixture f;
  const Case& c = GetParam();
  auto taught = f.taught();
  taught.maxParts = 5;
  auto loc = vgr::vision::makeLocator(c.method, f.templ.image, taught);
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  std::mt19937 rng(5);
  const auto truth = vgr::sim::synth::threePoses(rng, kSize, 60);
  const cv::Mat img = vgr::sim::synth::renderScene(f.part, truth, kSize, 5.0, 9);
  auto out = (*loc)->locate(img);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->parts.size(), 3u);
  std::vector<int> hit(3, 0);
  for (const auto& d : out->parts) {
    const auto& t = truth[vgr::sim::synth::nearestPose(truth, d.u, d.v)];
    ++hit[vgr::sim::synth::nearestPose(truth, d.u, d.v)];
    EXPECT_LT(std::hypot(d.u - t.u, d.v - t.v), c.posTolPx);
    EXPECT_LT(vgr::sim::synth::angleDiffDeg(d.angleDeg, t.angleDeg), c.angTolDeg);
  }
  EXPECT_EQ(hit, (std::vector<int>{1, 1, 1}));
  for (size_t k = 1; k < out->parts.size(); ++k) EXPECT_GE(out->parts[k - 1].score, out->parts[k].score);

  taught.maxParts = 2;
  loc = vgr::vision::makeLocator(c.method, f.templ.image, taught);
  ASSERT_TRUE(loc.has_value());
  out = (*loc)->locate(img);
  ASSERT_TRUE(out.has_value());
  EXPECT_EQ(out->parts.size(), 2u);
}

TEST_P(locate_feature_methods, BadParametersAreNamed) {
  const Fixture f;
  const Case& c = GetParam();
  auto taught = f.taught();
  taught.params = {{c.badParam, c.badValue}};
  auto bad = vgr::vision::makeLocator(c.method, f.templ.image, taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().code, vgr::Status::BadArgument);
  EXPECT_NE(bad.error().message.find(std::string(c.method) + ": parameter '" + c.badParam + "'"), std::string::npos) << bad.error().message;

  taught.params = {{"no_such_parameter", "1"}};
  bad = vgr::vision::makeLocator(c.method, f.templ.image, taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("unknown parameter 'no_such_parameter'"), std::string::npos) << bad.error().message;

  // A template without texture cannot be taught.
  bad = vgr::vision::makeLocator(c.method, cv::Mat(200, 200, CV_8U, cv::Scalar(30)), f.taught());
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find(c.method), std::string::npos) << bad.error().message;

  auto loc = vgr::vision::makeLocator(c.method, f.templ.image, f.taught());
  ASSERT_TRUE(loc.has_value());
  auto wrong = (*loc)->locate(cv::Mat(10, 10, CV_32F, cv::Scalar(0)));
  ASSERT_FALSE(wrong.has_value());
  EXPECT_EQ(wrong.error().code, vgr::Status::BadArgument);
}

INSTANTIATE_TEST_SUITE_P(Method, locate_feature_methods,
                         ::testing::Values(Case{"orb-ransac", 1.0, 0.3, "reproj_threshold_px", "0"},
                                           Case{"orb-prosac", 1.0, 0.3, "mu", "abc"},
                                           Case{"orb-adk", 1.0, 0.3, "angle_bound_deg", "90"},
                                           Case{"contour-weighted", 0.5, 0.1, "r_deg", "-1"}),
                         [](const ::testing::TestParamInfo<Case>& i) {
                           std::string n = i.param.method;
                           for (char& ch : n) if (ch == '-') ch = '_';
                           return n;
                         });

}  // namespace
