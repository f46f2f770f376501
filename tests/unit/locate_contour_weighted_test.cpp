// Method "contour-weighted" (paper 000) against synthetic images with known truth
// (tests/unit/locate_test_images.hpp): a textured part turned within +-60 degrees, noise
// sigma 5, 1280 x 1024.
#include <cmath>
#include <random>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "tests/unit/locate_test_images.hpp"
#include "vision/locate/locator.hpp"

namespace {

using vgr::test::PartPose;

const cv::Size kSize(1280, 1024);

struct Fixture {
  vgr::test::SynthPart part = vgr::test::makeTexturedPart(false);
  vgr::test::SynthTemplate templ = vgr::test::makeTemplate(part);
  vgr::vision::TaughtTemplate taught() const {
    vgr::vision::TaughtTemplate t;
    t.grasp = templ.grasp;
    t.minScore = 0.3;
    return t;
  }
};

TEST(locate_contour_weighted, FindsThePartWithinTolerance) {
  const Fixture f;
  auto loc = vgr::vision::makeLocator("contour-weighted", f.templ.image, f.taught());
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  EXPECT_EQ((*loc)->method(), "contour-weighted");
  std::mt19937 rng(11);
  double maxPos = 0, maxAng = 0;
  for (int k = 0; k < 4; ++k) {
    const PartPose truth = vgr::test::randomPose(rng, kSize, 60);
    const cv::Mat img = vgr::test::renderScene(f.part, {truth}, kSize, 5.0, 100 + k);
    auto out = (*loc)->locate(img);
    ASSERT_TRUE(out.has_value()) << out.error().message;
    ASSERT_EQ(out->parts.size(), 1u) << "image " << k;
    const auto& d = out->parts.front();
    maxPos = std::max(maxPos, std::hypot(d.u - truth.u, d.v - truth.v));
    maxAng = std::max(maxAng, vgr::test::angleDiffDeg(d.angleDeg, truth.angleDeg));
    EXPECT_GE(d.score, 0.3);
    EXPECT_LE(d.score, 1.0);
    EXPECT_FALSE(out->matches.empty());
    EXPECT_GE(out->candidateMatches, static_cast<int>(out->matches.size()));
    EXPECT_GE(vgr::test::matchTruePositiveRate(out->matches, truth, f.templ.grasp), 0.95);
  }
  // Homography from >= 100 ORB matches at sigma 5: well inside paper 000's 4 px / 0.5 deg.
  EXPECT_LT(maxPos, 0.5);
  EXPECT_LT(maxAng, 0.1);
  std::printf("max position error %.3f px, max angle error %.3f deg\n", maxPos, maxAng);
}

TEST(locate_contour_weighted, FindsNothingWithoutThePart) {
  const Fixture f;
  auto loc = vgr::vision::makeLocator("contour-weighted", f.templ.image, f.taught());
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  for (std::uint64_t seed : {1u, 2u}) {
    auto out = (*loc)->locate(vgr::test::renderDistractorScene(kSize, 5.0, seed));
    ASSERT_TRUE(out.has_value());
    EXPECT_TRUE(out->parts.empty()) << "seed " << seed << ": score " << out->parts.front().score;
  }
  auto out = (*loc)->locate(cv::Mat(kSize, CV_8U, cv::Scalar(vgr::test::kBackground)));
  ASSERT_TRUE(out.has_value());
  EXPECT_TRUE(out->parts.empty());
}

TEST(locate_contour_weighted, FindsThreeParts) {
  const Fixture f;
  auto taught = f.taught();
  taught.maxParts = 5;
  auto loc = vgr::vision::makeLocator("contour-weighted", f.templ.image, taught);
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  std::mt19937 rng(5);
  const auto truth = vgr::test::threePoses(rng, kSize, 60);
  const cv::Mat img = vgr::test::renderScene(f.part, truth, kSize, 5.0, 9);
  auto out = (*loc)->locate(img);
  ASSERT_TRUE(out.has_value());
  ASSERT_EQ(out->parts.size(), 3u);
  std::vector<int> hit(3, 0);
  for (const auto& d : out->parts) {
    const auto& t = truth[vgr::test::nearestPose(truth, d.u, d.v)];
    ++hit[vgr::test::nearestPose(truth, d.u, d.v)];
    EXPECT_LT(std::hypot(d.u - t.u, d.v - t.v), 0.5);
    EXPECT_LT(vgr::test::angleDiffDeg(d.angleDeg, t.angleDeg), 0.1);
  }
  EXPECT_EQ(hit, (std::vector<int>{1, 1, 1}));
  for (size_t k = 1; k < out->parts.size(); ++k) EXPECT_GE(out->parts[k - 1].score, out->parts[k].score);

  taught.maxParts = 2;
  loc = vgr::vision::makeLocator("contour-weighted", f.templ.image, taught);
  ASSERT_TRUE(loc.has_value());
  out = (*loc)->locate(img);
  ASSERT_TRUE(out.has_value());
  EXPECT_EQ(out->parts.size(), 2u);
}

TEST(locate_contour_weighted, BadParametersAreNamed) {
  const Fixture f;
  auto taught = f.taught();
  taught.params = {{"r_deg", "-1"}};
  auto bad = vgr::vision::makeLocator("contour-weighted", f.templ.image, taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().code, vgr::Status::BadArgument);
  EXPECT_NE(bad.error().message.find("contour-weighted: parameter 'r_deg'"), std::string::npos) << bad.error().message;

  taught.params = {{"no_such_parameter", "1"}};
  bad = vgr::vision::makeLocator("contour-weighted", f.templ.image, taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("unknown parameter 'no_such_parameter'"), std::string::npos) << bad.error().message;

  // A template without texture cannot be taught.
  bad = vgr::vision::makeLocator("contour-weighted", cv::Mat(200, 200, CV_8U, cv::Scalar(30)), f.taught());
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("contour-weighted"), std::string::npos) << bad.error().message;

  auto loc = vgr::vision::makeLocator("contour-weighted", f.templ.image, f.taught());
  ASSERT_TRUE(loc.has_value());
  auto wrong = (*loc)->locate(cv::Mat(10, 10, CV_32F, cv::Scalar(0)));
  ASSERT_FALSE(wrong.has_value());
  EXPECT_EQ(wrong.error().code, vgr::Status::BadArgument);
}

}  // namespace
