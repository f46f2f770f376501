// The skeleton's locator against the renderer's ground truth (no camera in between).
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "config/cell_config.hpp"
#include "sim/scene.hpp"
#include "vision/locate/moments_locator.hpp"

namespace {

vgr::sim::SceneRenderer simCell() {
  auto cfg = vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
  EXPECT_TRUE(cfg.has_value());
  return vgr::sim::SceneRenderer::fromCellConfig(*cfg);
}

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

TEST(MomentsLocator, FindsRenderedPartWithinTolerance) {
  const auto renderer = simCell();
  cv::Mat img;
  double maxPos = 0, maxAng = 0;
  for (std::uint64_t frame = 1; frame <= 60; ++frame) {
    const auto truth = renderer.render(frame, img);
    auto found = vgr::vision::locateByMoments(img, {});
    ASSERT_TRUE(found.has_value());
    ASSERT_EQ(found->size(), 1u) << "frame " << frame;
    const auto& d = found->front();
    maxPos = std::max(maxPos, std::hypot(d.u - truth.uPx, d.v - truth.vPx));
    maxAng = std::max(maxAng, angleDiff(d.angleDeg, truth.angleImgDeg));
    EXPECT_GT(d.score, 0.5);
  }
  // 0.5 mm/px in the sim cell: 0.2 px = 0.1 mm, well inside the demo's 0.5 mm bar.
  EXPECT_LT(maxPos, 0.2);
  EXPECT_LT(maxAng, 0.2);
  std::printf("max position error %.4f px, max angle error %.4f deg\n", maxPos, maxAng);
}

TEST(MomentsLocator, OrientationCoversFullCircle) {
  // The same pose turned in 30-degree steps: the third-order moment must keep the ends apart.
  const auto renderer = simCell();
  auto truth = renderer.truthForFrame(1);
  cv::Mat img;
  for (int a = -180; a < 180; a += 30) {
    truth.rzDeg = a;
    renderer.renderTruth(truth, 7, img);
    auto found = vgr::vision::locateByMoments(img, {});
    ASSERT_TRUE(found && found->size() == 1);
    // The sim camera looks down with its image x axis along base +y, image y along base +x:
    // a part direction (cos a, sin a) shows as (u, v) = (sin a, cos a), i.e. at a - 90 deg.
    const double expected = std::remainder(a - 90.0, 360.0);
    EXPECT_LT(angleDiff(found->front().angleDeg, expected), 0.3) << "rz " << a;
  }
}

TEST(MomentsLocator, EmptyConveyorFindsNothing) {
  cv::Mat img(1024, 1280, CV_8UC1, cv::Scalar(30));
  cv::Mat noise(img.size(), CV_8UC1);
  cv::randu(noise, 0, 6);
  img += noise;
  auto found = vgr::vision::locateByMoments(img, {});
  ASSERT_TRUE(found.has_value());
  EXPECT_TRUE(found->empty());
}

TEST(MomentsLocator, RejectsWrongImageType) {
  cv::Mat img(10, 10, CV_32F, cv::Scalar(0));
  auto found = vgr::vision::locateByMoments(img, {});
  ASSERT_FALSE(found.has_value());
  EXPECT_EQ(found.error().code, vgr::Status::BadArgument);
}

}  // namespace
