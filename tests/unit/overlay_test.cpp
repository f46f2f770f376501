// vision/overlay.hpp: the one overlay picture (vgrd's page, vgr locate --overlay, vgr eval
// --overlays): the grasp point's magenta disc where the part is, the ROI's yellow edge, the
// part's outline turned by its angle, the scale applied to coordinates, the caption; a depth
// frame's false colours (near red .. far blue, no data black, stray pixels not stretching the
// range), a 3D part's projected axes and the colour bar.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <limits>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

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

// The colour map's entry for value v (255 = near), straight from OpenCV: the test's own
// statement of the mapping, not the implementation's.
cv::Vec3b turbo(int v) {
  cv::Mat one(1, 1, CV_8UC1, cv::Scalar(v)), out;
  cv::applyColorMap(one, out, cv::COLORMAP_TURBO);
  return out.at<cv::Vec3b>(0, 0);
}

TEST(overlay, DepthFrameInFalseColourNearRedFarBlueNoDataBlackStrayPixelsIgnored) {
  // A bin floor at 900 mm, a part's top at 850 mm, a hole without data, and 20 stray pixels
  // at 300 mm (0.03 % of the frame: below the 0.5 % tails the range ignores).
  cv::Mat depth(240, 320, CV_32FC1, cv::Scalar(900.0f));
  depth(cv::Rect(100, 80, 60, 40)).setTo(850.0f);
  depth(cv::Rect(10, 10, 20, 20)).setTo(0.0f);
  depth.at<float>(200, 300) = std::numeric_limits<float>::quiet_NaN();
  for (int i = 0; i < 20; ++i) depth.at<float>(220, 10 + i) = 300.0f;
  cv::Mat bgr;
  const auto range = vgr::vision::colourDepth(depth, bgr);
  ASSERT_TRUE(range.has_value());
  ASSERT_EQ(bgr.type(), CV_8UC3);
  ASSERT_EQ(bgr.size(), depth.size());
  // 85 % of the valid pixels at 900 mm, 3 % at 850: the range is [850, 900] to a histogram bin.
  const double bin = (900.0 - 300.0) / 1024;
  EXPECT_NEAR(range->nearMm, 850.0, bin);
  EXPECT_NEAR(range->farMm, 900.0, bin);
  // z -> 255 (near) .. 0 (far) along the map, saturated outside the range.
  auto expected = [&](double z) {
    const double v = 255.0 * (range->farMm - z) / (range->farMm - range->nearMm);
    return turbo(static_cast<int>(std::clamp(std::lround(v), 0L, 255L)));
  };
  EXPECT_EQ(bgr.at<cv::Vec3b>(100, 130), expected(850)) << "the part: the near end";
  EXPECT_GE(expected(850)[2], 100);  // dark red: red stands out
  EXPECT_LT(expected(850)[0], 20);
  EXPECT_EQ(bgr.at<cv::Vec3b>(150, 250), expected(900)) << "the floor: the far end";
  EXPECT_GT(expected(900)[0], expected(900)[2] + 5);  // dark blue: blue stands out
  EXPECT_GT(expected(900)[0], expected(900)[1] + 30);
  EXPECT_EQ(bgr.at<cv::Vec3b>(20, 20), cv::Vec3b(0, 0, 0));     // no data (0)
  EXPECT_EQ(bgr.at<cv::Vec3b>(200, 300), cv::Vec3b(0, 0, 0));   // no data (NaN)
  EXPECT_EQ(bgr.at<cv::Vec3b>(220, 15), turbo(255));            // nearer than the range: the near colour
  EXPECT_EQ(vgr::vision::depthColour(875.0, *range), expected(875));
  EXPECT_EQ(vgr::vision::depthColour(200.0, *range), turbo(255));
  EXPECT_EQ(vgr::vision::depthColour(2000.0, *range), turbo(0));

  // Nothing valid: no range, all black.
  cv::Mat none(10, 10, CV_32FC1, cv::Scalar(0.0f));
  EXPECT_FALSE(vgr::vision::colourDepth(none, bgr).has_value());
  EXPECT_EQ(cv::countNonZero(bgr.reshape(1)), 0);
  // A flat frame: a 1 mm range about its z.
  cv::Mat flat(10, 10, CV_32FC1, cv::Scalar(500.0f));
  const auto r = vgr::vision::colourDepth(flat, bgr);
  ASSERT_TRUE(r.has_value());
  EXPECT_DOUBLE_EQ(r->nearMm, 499.5);
  EXPECT_DOUBLE_EQ(r->farMm, 500.5);
}

TEST(overlay, A3dPartIsItsProjectedGraspFrameWithTheDiscOnTopAndAColourBar) {
  const vgr::DepthIntrinsics k{800, 800, 319.5, 239.5, 640, 480};
  // The grasp frame at 800 mm, seen at pixel (400, 240), turned 90 deg about z: its x axis
  // points down the image (+y), its y axis to the left (-x).
  const vgr::Pose camFromGrasp = vgr::poseFromEulerZyxDeg(80.5, 0.5, 800, vgr::EulerZyxDeg{90, 0, 0});
  const OverlayPart p = vgr::vision::overlayPart3d(camFromGrasp, k, 0.9, 40);
  EXPECT_NEAR(p.u, 400, 1e-9);
  EXPECT_NEAR(p.v, 240, 1e-9);
  ASSERT_TRUE(p.axes3d);
  EXPECT_NEAR(p.axisEnds[0].x, p.u, 1e-9);
  EXPECT_NEAR(p.axisEnds[0].y, p.v + 40, 1e-9);  // x axis: 40 mm at 800 mm = 40 px down
  EXPECT_NEAR(p.axisEnds[1].x, p.u - 40, 1e-9);  // y axis: to the left
  EXPECT_NEAR(p.axisEnds[2].x, 319.5 + 800 * 80.5 / 840, 1e-9);  // z axis: away from the camera, towards the centre

  cv::Mat depth(480, 640, CV_32FC1, cv::Scalar(900.0f)), bgr;
  depth(cv::Rect(380, 200, 80, 80)).setTo(800.0f);
  OverlayFrame f;
  f.parts = {p};
  f.depthRange = vgr::vision::colourDepth(depth, bgr);
  f.caption = "cycle 3  job 1  OK  1 part";
  const cv::Mat out = vgr::vision::drawOverlay(bgr, f);
  ASSERT_EQ(out.size(), depth.size());
  // The disc on top of the axes' origin, the axes' colours along them (x red, y green).
  EXPECT_TRUE(magenta(out.at<cv::Vec3b>(240, 400)));
  const cv::Vec3b xAxis = out.at<cv::Vec3b>(240 + 25, 400), yAxis = out.at<cv::Vec3b>(240, 400 - 25);
  EXPECT_TRUE(xAxis[2] > 200 && xAxis[1] < 90 && xAxis[0] < 90) << xAxis;
  EXPECT_TRUE(green(yAxis)) << yAxis;
  // No in-plane arrow (it would point right, along +x of the image, at angle 0).
  EXPECT_FALSE(green(out.at<cv::Vec3b>(240, 400 + 20)));
  // The colour bar at the right edge: near colour at its top, far at its bottom, on black.
  const int barX = 640 - 4 - 640 / 48 / 2, top = (480 - 240) / 2;
  EXPECT_EQ(out.at<cv::Vec3b>(top, barX), turbo(255));
  EXPECT_EQ(out.at<cv::Vec3b>(top + 239, barX), turbo(0));
  EXPECT_EQ(out.at<cv::Vec3b>(top + 120, barX), turbo(127));
  EXPECT_EQ(out.at<cv::Vec3b>(top + 120, 640 - 2), cv::Vec3b(0, 0, 0));
}

}  // namespace
