// The taught `moments` method checks the blob's shape against the template's blob
// (vision/locate/moments_locator.hpp): on an image of mixed shapes of similar size it finds
// the taught part and no other shape; on an image without it, no part.
#include <cmath>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "vision/locate/moments_locator.hpp"

namespace {

// The taught part in template px: a 60 x 40 px plate with a 16 x 16 px tab (its ends told apart).
const std::vector<cv::Point2d> kPart = {{30, 20}, {106, 20}, {106, 36}, {90, 36}, {90, 60}, {30, 60}};

void fill(cv::Mat& img, const std::vector<cv::Point2d>& poly, cv::Point2d shift, double angleDeg, cv::Point2d about) {
  const double a = angleDeg * CV_PI / 180, c = std::cos(a), s = std::sin(a);
  std::vector<cv::Point> pts;
  for (const auto& p : poly) {
    const cv::Point2d d = p - about;
    // Counter-clockwise as displayed (y down).
    pts.emplace_back(cvRound(about.x + shift.x + c * d.x + s * d.y), cvRound(about.y + shift.y - s * d.x + c * d.y));
  }
  cv::fillPoly(img, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(220), cv::LINE_AA);
}

// Shapes of about the part's area (2656 px²) that are not the part.
void distractors(cv::Mat& img) {
  fill(img, {{0, 0}, {110, 0}, {0, 48}}, {500, 60}, 0, {0, 0});                        // a right triangle
  fill(img, {{0, 0}, {130, 0}, {130, 14}, {70, 14}, {70, 30}, {0, 30}}, {100, 420}, 20, {0, 0});  // a long bar with a step
  fill(img, {{0, 0}, {52, 0}, {52, 52}, {26, 60}, {0, 52}}, {560, 380}, 0, {0, 0});      // a house
}

vgr::TaughtTemplate taught() {
  vgr::TaughtTemplate t;
  t.grasp = {60, 40};
  t.maxParts = 8;
  t.minScore = 0;
  return t;
}

cv::Mat templateImage() {
  cv::Mat t(80, 140, CV_8UC1, cv::Scalar(20));
  fill(t, kPart, {0, 0}, 0, {0, 0});
  return t;
}

TEST(moments_shape, FindsTheTaughtShapeAmongOthers) {
  auto loc = vgr::vision::makeMomentsLocator(templateImage(), taught());
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  cv::Mat scene(600, 800, CV_8UC1, cv::Scalar(20));
  distractors(scene);
  fill(scene, kPart, {300, 200}, 30, {60, 40});  // grasp (60, 40) -> (360, 240), turned 30 deg
  auto r = (*loc)->locate(scene);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  ASSERT_EQ(r->parts.size(), 1u) << "shapes that are not the part were reported";
  EXPECT_NEAR(r->parts[0].u, 360, 1.0);
  EXPECT_NEAR(r->parts[0].v, 240, 1.0);
  EXPECT_NEAR(r->parts[0].angleDeg, 30, 1.0);
}

TEST(moments_shape, OtherShapesAloneAreNoPart) {
  auto loc = vgr::vision::makeMomentsLocator(templateImage(), taught());
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  cv::Mat scene(600, 800, CV_8UC1, cv::Scalar(20));
  distractors(scene);
  auto r = (*loc)->locate(scene);
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_TRUE(r->parts.empty()) << r->parts.size() << " wrong shape(s) reported as the part";
}

TEST(moments_shape, TheUntaughtLocatorStillTakesEveryBlob) {
  auto loc = vgr::vision::makeUntaughtMomentsLocator({});
  cv::Mat scene(600, 800, CV_8UC1, cv::Scalar(20));
  distractors(scene);
  auto r = loc->locate(scene);
  ASSERT_TRUE(r.has_value());
  EXPECT_EQ(r->parts.size(), 3u);
}

}  // namespace
