// The Locator interface and factory (vision/locate/locator.hpp) with the "moments" method:
// a grasp point away from the centroid must follow the part's rotation, and parameters from
// job.yaml are range-checked by name.
#include <cmath>
#include <numbers>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "config/cell_config.hpp"
#include "sim/scene.hpp"
#include "vision/locate/locator.hpp"

namespace {

vgr::sim::SceneRenderer simCell() {
  auto cfg = vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
  EXPECT_TRUE(cfg.has_value());
  return vgr::sim::SceneRenderer::fromCellConfig(*cfg);
}

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

// A point `lever` px along the part's +x axis from its centroid, as displayed (y down).
vgr::vision::PixelPoint alongAxis(const vgr::sim::SceneTruth& t, double lever) {
  const double a = t.angleImgDeg * std::numbers::pi / 180.0;
  return {t.uPx + lever * std::cos(a), t.vPx - lever * std::sin(a)};
}

TEST(locator_interface, MomentsTransfersAnOffCentreGraspPointAndReportsRotationFromTemplate) {
  const auto renderer = simCell();
  cv::Mat templ, img;
  const auto t0 = renderer.render(1, templ);
  vgr::vision::TaughtTemplate taught;
  taught.grasp = alongAxis(t0, 40.0);
  auto locator = vgr::vision::makeLocator("moments", templ, taught);
  ASSERT_TRUE(locator.has_value()) << locator.error().message;
  EXPECT_EQ((*locator)->method(), "moments");

  double maxPos = 0, maxAng = 0;
  for (std::uint64_t frame = 2; frame <= 40; ++frame) {
    const auto t = renderer.render(frame, img);
    auto out = (*locator)->locate(img);
    ASSERT_TRUE(out.has_value()) << out.error().message;
    ASSERT_EQ(out->parts.size(), 1u) << "frame " << frame;
    const auto& d = out->parts.front();
    const auto expected = alongAxis(t, 40.0);
    maxPos = std::max(maxPos, std::hypot(d.u - expected.u, d.v - expected.v));
    maxAng = std::max(maxAng, angleDiff(d.angleDeg, t.angleImgDeg - t0.angleImgDeg));
  }
  // The centroid is within 0.2 px (moments_locator_test); 0.2 deg at a 40 px lever adds 0.14 px.
  EXPECT_LT(maxPos, 0.35);
  EXPECT_LT(maxAng, 0.2);
}

TEST(locator_interface, BadParametersAreNamed) {
  cv::Mat templ;
  simCell().render(1, templ);
  vgr::vision::TaughtTemplate taught;
  taught.params["threshold"] = "300";
  auto bad = vgr::vision::makeLocator("moments", templ, taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("'threshold'"), std::string::npos) << bad.error().message;

  taught.params = {{"treshold", "10"}};
  bad = vgr::vision::makeLocator("moments", templ, taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("unknown parameter 'treshold'"), std::string::npos) << bad.error().message;

  taught.params.clear();
  bad = vgr::vision::makeLocator("no-such-method", templ, taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("no-such-method"), std::string::npos);
}

TEST(locator_interface, EmptyTemplateIsRefused) {
  auto bad = vgr::vision::makeLocator("moments", cv::Mat(), {});
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().code, vgr::Status::BadArgument);
}

}  // namespace
