// Every method, handed an image it cannot search, says why (vision/locate/locator.hpp): an
// image smaller than the template, a search ROI outside the image; not "expected a
// non-empty 8-bit gray image".
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "vision/locate/locator.hpp"

namespace {

// A textured template (a plate with holes and marks) so that every method can be built.
cv::Mat templateImage() {
  cv::Mat t(150, 200, CV_8UC1, cv::Scalar(30));
  cv::rectangle(t, cv::Rect(30, 25, 140, 100), cv::Scalar(200), cv::FILLED);
  cv::rectangle(t, cv::Rect(150, 25, 20, 20), cv::Scalar(30), cv::FILLED);
  cv::circle(t, {70, 75}, 12, cv::Scalar(40), cv::FILLED);
  cv::RNG rng(7);
  for (int i = 0; i < 60; ++i)
    cv::circle(t, {rng.uniform(40, 160), rng.uniform(35, 115)}, rng.uniform(2, 5), cv::Scalar(rng.uniform(60, 255)), cv::FILLED);
  return t;
}

TEST(locate_input, AnImageSmallerThanTheTemplateIsNamed) {
  const cv::Mat t = templateImage();
  vgr::TaughtTemplate taught;
  taught.grasp = {100, 75};
  int built = 0;
  for (const auto& method : vgr::vision::locatorMethods()) {
    auto loc = vgr::vision::makeLocator(method, t, taught);
    if (!loc) continue;
    ++built;
    auto r = (*loc)->locate(cv::Mat(60, 80, CV_8UC1, cv::Scalar(30)));
    ASSERT_FALSE(r.has_value()) << method << ": a 80x60 image searched for a 200x150 template";
    EXPECT_NE(r.error().message.find("80x60 px image is smaller than the 200x150 px template"), std::string::npos)
        << method << ": " << r.error().message;
  }
  EXPECT_GE(built, 5);
}

TEST(locate_input, ASearchRoiOutsideTheImageIsNamed) {
  const cv::Mat t = templateImage();
  vgr::TaughtTemplate taught;
  taught.grasp = {100, 75};
  taught.searchRoi = {1000, 900, 300, 200};
  for (const auto& method : vgr::vision::locatorMethods()) {
    auto loc = vgr::vision::makeLocator(method, t, taught);
    if (!loc) continue;
    auto r = (*loc)->locate(cv::Mat(480, 640, CV_8UC1, cv::Scalar(30)));
    ASSERT_FALSE(r.has_value()) << method;
    EXPECT_NE(r.error().message.find("search ROI 1000,900 300x200 lies outside the 640x480 px image"), std::string::npos)
        << method << ": " << r.error().message;
  }
}

TEST(locate_input, AWrongImageTypeStillSaysSo) {
  const cv::Mat t = templateImage();
  vgr::TaughtTemplate taught;
  taught.grasp = {100, 75};
  auto loc = vgr::vision::makeLocator("shape", t, taught);
  ASSERT_TRUE(loc.has_value()) << loc.error().message;
  auto r = (*loc)->locate(cv::Mat(480, 640, CV_8UC3, cv::Scalar(30, 30, 30)));
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find("8-bit gray"), std::string::npos) << r.error().message;
}

}  // namespace
