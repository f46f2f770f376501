// The shape matcher's model and edge estimator (vision/locate/shape_model.hpp) on noise-free
// images whose edges lie exactly on pixel borders: the two pixels either side of such an edge
// have equal gradients, and the edge is on their border. (Before: the estimator took the first
// of the two equal samples as the maximum, found it at the end of its window and gave up, so
// every edge on a pixel border whose normal points to +x or +y stayed 0.5 px off in the model,
// and a noise-free template put its scenes 0.1 px off.)
#include <cmath>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "vision/locate/shape_matcher.hpp"
#include "vision/locate/shape_model.hpp"

namespace {

using vgr::vision::shape::edgeAlongNormal;

// A bright rectangle on a dark background, its borders between pixels: x in [20.5, 60.5], y in
// [15.5, 45.5] (pixel centres at integers).
cv::Mat rectangleImage() {
  cv::Mat img(64, 80, CV_8UC1, cv::Scalar(30));
  img(cv::Rect(21, 16, 40, 30)).setTo(190);
  return img;
}

TEST(shape_model, AnEdgeBetweenTwoPixelsIsOnTheirBorder) {
  // A gradient profile across a vertical edge at x = 10.5: two equal samples either side.
  cv::Mat gx(5, 20, CV_32F, cv::Scalar(0)), gy(5, 20, CV_32F, cv::Scalar(0));
  const float profile[] = {2, 12, 40, 40, 12, 2};
  for (int y = 0; y < gx.rows; ++y)
    for (int i = 0; i < 6; ++i) gx.at<float>(y, 8 + i) = profile[i];
  double t = 0, mag = 0;
  // From the pixel right of the edge, looking +-1 px along +x (the edge extraction's window):
  // the samples are 40, 40, 12; the peak lies between the first two.
  ASSERT_TRUE(edgeAlongNormal(gx, gy, 11, 2, 1, 0, 1, 1, false, 5, t, mag));
  EXPECT_NEAR(t, -0.5, 1e-9);
  // From the pixel left of it: 12, 40, 40.
  ASSERT_TRUE(edgeAlongNormal(gx, gy, 10, 2, 1, 0, 1, 1, false, 5, t, mag));
  EXPECT_NEAR(t, 0.5, 1e-9);
  // Along -x from the left pixel: 40, 40, 12 again.
  ASSERT_TRUE(edgeAlongNormal(gx, gy, 10, 2, -1, 0, 1, -1, false, 5, t, mag));
  EXPECT_NEAR(t, -0.5, 1e-9);
  // A window whose end is really the highest: no interior peak.
  EXPECT_FALSE(edgeAlongNormal(gx, gy, 12, 2, 1, 0, 1, 1, false, 5, t, mag));
}

TEST(shape_model, ModelPointsOfARectangleLieOnItsBorders) {
  const cv::Mat img = rectangleImage();
  vgr::vision::ShapeParams p;
  auto model = vgr::vision::shape::buildModel(img, p);
  ASSERT_TRUE(model.has_value()) << model.error().message;
  const auto& l0 = model->levels[0];
  int straight = 0;
  for (int k = 0; k < l0.size(); ++k) {
    const double x = l0.x[k] + model->origin.u, y = l0.y[k] + model->origin.v;
    // Points along the straight parts of the sides (the corners are rounded by the blur).
    if (std::abs(l0.nx[k]) > 0.999 && y > 20 && y < 41) {
      EXPECT_NEAR(std::abs(x - 40.5), 20.0, 0.01) << "at (" << x << ", " << y << ")";
      ++straight;
    }
    if (std::abs(l0.ny[k]) > 0.999 && x > 25 && x < 56) {
      EXPECT_NEAR(std::abs(y - 30.5), 15.0, 0.01) << "at (" << x << ", " << y << ")";
      ++straight;
    }
  }
  EXPECT_GT(straight, 80);
  // The origin is the points' centroid: the rectangle's centre.
  EXPECT_NEAR(model->origin.u, 40.5, 0.05);
  EXPECT_NEAR(model->origin.v, 30.5, 0.05);
}

}  // namespace
