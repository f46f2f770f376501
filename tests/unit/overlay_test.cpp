// vision/overlay.hpp: the one overlay picture (vgrd's page, vgr locate --overlay, vgr eval
// --overlays): the grasp point's magenta disc where the part is, the ROI's yellow edge, the
// part's outline turned by its angle, the scale applied to coordinates, the caption.
#include <gtest/gtest.h>

#include <opencv2/core.hpp>

#include "vision/overlay.hpp"

namespace {

using vgr::vision::OverlayFrame;
using vgr::vision::OverlayPart;

bool magenta(const cv::Vec3b& p) { return p[0] > 200 && p[1] < 60 && p[2] > 200; }  // BGR
// Lines are anti-aliased: an edge on a half pixel is half its colour on each side, so the
// colour tests look at the hue (which channels stand out), not at full intensity.
bool green(const cv::Vec3b& p) { return p[1] > p[0] + 40 && p[1] > p[2] + 40; }
bool yellow(const cv::Vec3b& p) { return p[2] > p[0] + 60 && p[1] > p[0] + 50; }

TEST(overlay, GraspDiscSitsOnThePartAndNowhereElse) {
  const cv::Mat gray(400, 600, CV_8UC1, cv::Scalar(40));
  OverlayFrame f;
  f.parts = {{150.0, 300.0, 30.0, 0.97, 0}, {420.5, 80.25, -90.0, 0.81, 3}};
  const cv::Mat out = vgr::vision::drawOverlay(gray, f);
  ASSERT_EQ(out.type(), CV_8UC3);
  ASSERT_EQ(out.size(), gray.size());
  EXPECT_TRUE(magenta(out.at<cv::Vec3b>(300, 150)));
  EXPECT_TRUE(magenta(out.at<cv::Vec3b>(80, 420)));
  EXPECT_TRUE(magenta(out.at<cv::Vec3b>(300, 150 + vgr::vision::kGraspRadiusPx - 2)));
  EXPECT_FALSE(magenta(out.at<cv::Vec3b>(300, 150 + vgr::vision::kGraspRadiusPx + 4)));
  int count = 0;
  for (int r = 0; r < out.rows; ++r)
    for (int c = 0; c < out.cols; ++c) count += magenta(out.at<cv::Vec3b>(r, c));
  // Two discs of radius 7: about 2 * pi * 49 = 308 px, give or take the anti-aliased rim.
  EXPECT_GT(count, 250);
  EXPECT_LT(count, 360);
}

TEST(overlay, RoiEdgeAndTemplateOutlineTurnWithThePart) {
  const cv::Mat gray(400, 600, CV_8UC1, cv::Scalar(40));
  OverlayFrame f;
  f.job.searchRoi = {100, 50, 300, 200};
  f.job.templateWidth = 101;
  f.job.templateHeight = 41;
  f.job.templateGrasp = {50, 20};
  f.parts = {{300.0, 250.0, 90.0, 0.9, 0}};  // turned 90 deg CCW as displayed: the long side is vertical
  const cv::Mat out = vgr::vision::drawOverlay(gray, f);
  // ROI: drawn on its boundary pixels, x = 100 and y = 50.
  EXPECT_TRUE(yellow(out.at<cv::Vec3b>(150, 100)));
  EXPECT_TRUE(yellow(out.at<cv::Vec3b>(50, 200)));
  EXPECT_TRUE(yellow(out.at<cv::Vec3b>(150, 399)));
  EXPECT_FALSE(yellow(out.at<cv::Vec3b>(150, 98)));
  EXPECT_FALSE(yellow(out.at<cv::Vec3b>(150, 200)));
  // Outline: the template's 101 px side now runs vertically through y = 250 +- 50.5 at x = 300 +- 20.5.
  auto greenNear = [&](int row, int col) {
    for (int d = -1; d <= 1; ++d)
      if (green(out.at<cv::Vec3b>(row, col + d))) return true;
    return false;
  };
  EXPECT_TRUE(greenNear(230, 280) || greenNear(230, 279));  // left long side (x = 300 - 20.5)
  EXPECT_TRUE(greenNear(230, 320) || greenNear(230, 321));  // right long side
  EXPECT_FALSE(greenNear(230, 250));                        // where the unturned outline's end would be
}

TEST(overlay, ScaleMovesEveryMarkWithTheImage) {
  const cv::Mat gray(1000, 1600, CV_8UC1, cv::Scalar(40));
  OverlayFrame f;
  f.parts = {{800.0, 400.0, 0.0, 1.0, 0}};
  f.caption = "cycle 1  job 1  OK  1 part";
  const double scale = vgr::vision::overlayScaleFor(gray.cols, 800);
  EXPECT_DOUBLE_EQ(scale, 0.5);
  const cv::Mat out = vgr::vision::drawOverlay(gray, f, scale);
  ASSERT_EQ(out.cols, 800);
  ASSERT_EQ(out.rows, 500);
  EXPECT_TRUE(magenta(out.at<cv::Vec3b>(200, 400)));  // (800.5 * 0.5 - 0.5, 400.5 * 0.5 - 0.5) = (399.75, 199.75)
  // The caption banner: black with green text in the top-left corner.
  EXPECT_EQ(out.at<cv::Vec3b>(2, 2), cv::Vec3b(0, 0, 0));
  EXPECT_DOUBLE_EQ(vgr::vision::overlayScaleFor(640, 800), 1.0);
}

TEST(overlay, PartsAndCaptionFromACycleResult) {
  vgr::PartResult p;
  p.uPx = 12.5;
  p.vPx = 7.25;
  p.angleImgDeg = -45;
  p.score = 0.5;
  p.label = 2;
  p.confidence = 0.875;
  const auto parts = vgr::vision::overlayParts(std::vector<vgr::PartResult>{p});
  ASSERT_EQ(parts.size(), 1u);
  EXPECT_EQ(parts[0].u, 12.5);
  EXPECT_EQ(parts[0].v, 7.25);
  EXPECT_EQ(parts[0].angleDeg, -45);
  EXPECT_EQ(parts[0].label, 2);
  EXPECT_EQ(parts[0].confidence, 0.875);  // drawn next to the label
  EXPECT_EQ(vgr::vision::cycleCaption(17, 1, vgr::Status::Ok, 2), "cycle 17  job 1  OK  2 parts");
  EXPECT_EQ(vgr::vision::cycleCaption(18, 1, vgr::Status::CameraError, 0), "cycle 18  job 1  -4 CAMERA_ERROR");
}

}  // namespace
