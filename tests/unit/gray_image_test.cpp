// One conversion from camera samples to 8-bit gray (vision/gray_image.hpp): a Mono12 frame
// saved as `vgr grab --save` saves it and read back by the offline tools is exactly the
// image vgrd locates in, not the black image of its top 8 of 16 bits.
#include <unistd.h>

#include <filesystem>
#include <string>

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "vision/gray_image.hpp"

namespace {

namespace fs = std::filesystem;

TEST(gray_image, ASavedMono12FrameReadsBackAsVgrdSeesIt) {
  // A Mono12 frame: a ramp over 0..4095 (LSB-aligned, as GenICam delivers it).
  cv::Mat frame(64, 4096 / 64, CV_16UC1);
  for (int i = 0; i < frame.rows * frame.cols; ++i) frame.at<std::uint16_t>(i / frame.cols, i % frame.cols) = static_cast<std::uint16_t>(i);
  cv::Mat vgrd;
  vgr::vision::toGray8(frame, 12, vgrd);
  double lo = 0, hi = 0;
  cv::minMaxLoc(vgrd, &lo, &hi);
  EXPECT_EQ(lo, 0);
  EXPECT_EQ(hi, 255);

  const fs::path path = fs::temp_directory_path() / fmt::format("vgr-gray-image-{}.png", ::getpid());
  ASSERT_TRUE(cv::imwrite(path.string(), vgr::vision::toFullRange16(frame, 12)));
  auto back = vgr::vision::readGray8(path.string());
  fs::remove(path);
  ASSERT_TRUE(back.has_value()) << back.error().message;
  ASSERT_EQ(back->type(), CV_8UC1);
  cv::minMaxLoc(*back, &lo, &hi);
  EXPECT_EQ(hi, 255) << "the saved frame reads back dark";
  EXPECT_EQ(cv::norm(*back, vgrd, cv::NORM_INF), 0) << "the tools and vgrd see different images";
}

// A 16-bit file holding LSB-aligned Mono12 samples (0..4095: another tool's save, or vgr
// grab before the full-range convention) read as full range is nearly black (max 16 of 255)
// and every method then finds nothing, silently. It is refused with the reason.
TEST(gray_image, LsbAlignedSixteenBitSamplesAreRefusedNotReadBlack) {
  cv::Mat frame(64, 4096 / 64, CV_16UC1);
  for (int i = 0; i < frame.rows * frame.cols; ++i) frame.at<std::uint16_t>(i / frame.cols, i % frame.cols) = static_cast<std::uint16_t>(i);
  const fs::path path = fs::temp_directory_path() / fmt::format("vgr-gray-image-lsb-{}.png", ::getpid());
  ASSERT_TRUE(cv::imwrite(path.string(), frame));  // unscaled: 0..4095
  auto back = vgr::vision::readGray8(path.string());
  fs::remove(path);
  ASSERT_FALSE(back.has_value()) << "a 0..4095 16-bit image read as an 8-bit image of max "
                                 << [&] { double hi = 0; cv::minMaxLoc(*back, nullptr, &hi); return hi; }();
  EXPECT_NE(back.error().message.find(path.string()), std::string::npos) << back.error().message;
  EXPECT_NE(back.error().message.find("4095"), std::string::npos) << back.error().message;
}

TEST(gray_image, EightBitImagesPassUnchanged) {
  cv::Mat img(10, 10, CV_8UC1, cv::Scalar(77));
  const fs::path path = fs::temp_directory_path() / fmt::format("vgr-gray-image8-{}.png", ::getpid());
  ASSERT_TRUE(cv::imwrite(path.string(), img));
  auto back = vgr::vision::readGray8(path.string());
  fs::remove(path);
  ASSERT_TRUE(back.has_value());
  EXPECT_EQ(cv::norm(*back, img, cv::NORM_INF), 0);
  EXPECT_FALSE(vgr::vision::readGray8("/nonexistent.png").has_value());
}

}  // namespace
