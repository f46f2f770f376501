// `vgr calibrate synth / intrinsics --pattern charuco` in-process (tools/vgr/calibrate_*.cpp): a
// rendered ChArUco set with partial views calibrates and writes the std devs; a board that is
// never found is an error naming every image and what to check. Files in a temporary
// folder, no sockets.
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tools/vgr/calibrate_intrinsics.hpp"
#include "tools/vgr/calibrate_synth.hpp"
#include "vision/calib/intrinsics.hpp"

namespace {

namespace fs = std::filesystem;

class calib_charuco_cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vgr-charuco-cli-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  static vgr::tools::CalibPatternOptions board() {
    vgr::tools::CalibPatternOptions p;
    p.pattern = "charuco";
    p.cols = 11;
    p.rows = 8;
    p.squareMm = 20;
    p.markerMm = 15;
    return p;
  }
  fs::path dir_;
};

TEST_F(calib_charuco_cli, rendered_partial_views_calibrate) {
  vgr::tools::CalibSynthOptions s;
  s.kind = "intrinsics";
  s.out = (dir_ / "set").string();
  s.pattern = board();
  s.views = 16;
  s.distanceMm = 420;
  s.maxTiltDeg = 35;
  s.partialShare = 0.5;
  ASSERT_EQ(vgr::tools::runCalibrateSynth(s), 0);
  vgr::tools::CalibIntrinsicsOptions o;
  o.images = s.out + "/plate_*.png";
  o.pattern = board();
  o.out = s.out + "/intrinsics.yaml";
  ::testing::internal::CaptureStderr();
  const int rc = vgr::tools::runCalibrateIntrinsics(o);
  const std::string err = ::testing::internal::GetCapturedStderr();
  ASSERT_EQ(rc, 0) << err;
  EXPECT_NE(err.find("(partial view)"), std::string::npos) << err;
  auto cam = vgr::vision::calib::readIntrinsics(o.out);
  ASSERT_TRUE(cam) << cam.error().message;
  EXPECT_EQ(cam->views.size(), 16u);
  EXPECT_LT(cam->rmsPx, 0.15);
  // 16 views: a pipeline check (the accuracy bar is asserted in calib_intrinsics).
  EXPECT_NEAR(cam->fx(), 900.0, 4.5);
  EXPECT_NEAR(cam->cx(), 403.7, 3.0);
  EXPECT_TRUE(cam->tangential);
  for (int i = 0; i < 4; ++i) EXPECT_GT(cam->stdDev[i], 0.0) << i;  // written and read back
}

TEST_F(calib_charuco_cli, a_board_never_found_names_the_images) {
  cv::imwrite((dir_ / "a.png").string(), cv::Mat(600, 800, CV_8UC1, cv::Scalar(120)));
  cv::imwrite((dir_ / "b.png").string(), cv::Mat(600, 800, CV_8UC1, cv::Scalar(60)));
  vgr::tools::CalibIntrinsicsOptions o;
  o.images = (dir_ / "*.png").string();
  o.pattern = board();
  o.out = (dir_ / "i.yaml").string();
  ::testing::internal::CaptureStderr();
  const int rc = vgr::tools::runCalibrateIntrinsics(o);
  const std::string err = ::testing::internal::GetCapturedStderr();
  EXPECT_EQ(rc, 2);
  EXPECT_NE(err.find("the charuco 11x8 was found in none of the 2 images (a.png, b.png)"), std::string::npos) << err;
  EXPECT_NE(err.find("check --dict (now DICT_5X5_100)"), std::string::npos) << err;
  EXPECT_NE(err.find("a.png: pattern NOT found: no DICT_5X5_100 marker found"), std::string::npos) << err;
  EXPECT_FALSE(fs::exists(o.out));
  // Bad board options are refused before any image is read, naming the value.
  o.pattern.dictionary = "DICT_5X5_10";
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(vgr::tools::runCalibrateIntrinsics(o), 2);
  EXPECT_NE(::testing::internal::GetCapturedStderr().find("--dict 'DICT_5X5_10'"), std::string::npos);
  o.pattern = board();
  o.pattern.markerMm = 25;
  ::testing::internal::CaptureStderr();
  EXPECT_EQ(vgr::tools::runCalibrateIntrinsics(o), 2);
  EXPECT_NE(::testing::internal::GetCapturedStderr().find("--marker 25"), std::string::npos);
}

}  // namespace
