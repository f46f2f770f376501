// `vgr calibrate synth --kind handeye-cloud` and `vgr calibrate handeye --cloud` (issue 14,
// paper 003's point-cloud hand-eye with a depth camera) as a user runs them: a rendered set
// of 15 depth images (0.3 mm noise, robot 0.05 mm / 0.01 deg), then the calibration with the
// truth: the chosen X within 0.5 mm / 0.1 deg, every method in the table; and the inputs a
// user gets wrong, each one line and exit 2.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/support/command.hpp"

namespace {

namespace fs = std::filesystem;

class calib_cloud_cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vgr-calib-cloud-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }
  fs::path dir_;
};

TEST_F(calib_cloud_cli, SynthThenCalibrateMeetsTheBarWithEveryMethodListed) {
  const std::string set = (dir_ / "set").string();
  auto synth = vgr::test::runVgr("calibrate synth --kind handeye-cloud --configuration eye-to-hand --views 15 --seed 4 "
                                 "--pose-format ur --out " + set);
  ASSERT_EQ(synth.exitCode, 0) << synth.out;
  for (const char* f : {"camera.yaml", "target.yaml", "poses.txt", "truth.yaml", "images/pose_000.png"})
    EXPECT_TRUE(fs::exists(fs::path(set) / f)) << f;
  auto r = vgr::test::runVgr("calibrate handeye --cloud --folder " + set + " --configuration auto --truth " + set +
                             "/truth.yaml --json --out " + (dir_ / "handeye.yaml").string());
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto j = nlohmann::json::parse(vgr::test::lastLine(r.out), nullptr, false);
  ASSERT_FALSE(j.is_discarded()) << r.out;
  EXPECT_EQ(j["configuration"], "eye-to-hand");
  EXPECT_EQ(j["method"], "refined");
  EXPECT_LT(j["point_mm"].get<double>(), 0.5);
  bool registration = false;
  for (const auto& m : j["methods"]) {
    if (m["method"] == j["method"]) {
      EXPECT_LT(m["err_x_mm"].get<double>(), 0.5) << m.dump();
      EXPECT_LT(m["err_x_deg"].get<double>(), 0.1) << m.dump();
    }
    registration = registration || m["method"] == "registration";
  }
  EXPECT_TRUE(registration) << "paper 003's registration is in the table";
  EXPECT_EQ(j["methods"].size(), 10u);  // 7 closed forms, registration, refined-points, refined
  EXPECT_TRUE(fs::exists(dir_ / "handeye.yaml"));
}

TEST_F(calib_cloud_cli, BadInputIsOneLineAndExitTwo) {
  const std::string set = (dir_ / "set").string();
  ASSERT_EQ(vgr::test::runVgr("calibrate synth --kind handeye-cloud --views 4 --out " + set).exitCode, 0);
  // --intrinsics belongs to a 2D camera.
  auto r = vgr::test::runVgr("calibrate handeye --cloud --folder " + set + " --intrinsics x.yaml --out " +
                             (dir_ / "h.yaml").string());
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("--intrinsics goes with a 2D camera"), std::string::npos) << r.out;
  // No target file.
  r = vgr::test::runVgr("calibrate handeye --cloud --folder " + set + " --target " + (dir_ / "none.yaml").string() +
                        " --out " + (dir_ / "h.yaml").string());
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("none.yaml: no such target file"), std::string::npos) << r.out;
  // An 8-bit image where a 16-bit depth image belongs.
  cv::imwrite(set + "/images/pose_001.png", cv::Mat(480, 640, CV_8UC1, cv::Scalar(7)));
  r = vgr::test::runVgr("calibrate handeye --cloud --folder " + set + " --out " + (dir_ / "h.yaml").string());
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("pose_001.png: not a 16-bit single-channel depth image"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(dir_ / "h.yaml"));
}

}  // namespace
