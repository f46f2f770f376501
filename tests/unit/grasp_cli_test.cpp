// The grasp commands end to end through the real `vgr` binary: `vgr sim render --3d --grasps`,
// `vgr eval --grasp`, `vgr grasp detect` (with the 3D calibration), `vgr grasp tensors`, and
// their one-line errors for bad input (docs/grasp.md).
#include <algorithm>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <set>
#include <sstream>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

#include "config/grasp_truth_file.hpp"
#include "tests/support/command.hpp"
#include "vision/calib/handeye.hpp"

namespace {

namespace fs = std::filesystem;
using vgr::test::lastLine;
using vgr::test::runVgr;

const std::string kModel = vgr::test::sourcePath("models/grasp/ggcnn.onnx");

class GraspCli : public ::testing::Test {
 protected:
  static void SetUpTestSuite() {
    dir_ = (fs::temp_directory_path() / ("vgr-grasp-cli-" + std::to_string(::getpid()))).string();
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    const auto r = runVgr("sim render --3d --grasps --part bracket --parts 2 --clutter 4 --count 6 --views 0 --seed 31 --out " + dir_ +
                          "/set");
    ASSERT_EQ(r.exitCode, 0) << r.out;
  }
  static void TearDownTestSuite() { fs::remove_all(dir_); }
  static std::string dir_;
};
std::string GraspCli::dir_;

TEST_F(GraspCli, RenderWritesGraspTruthForEveryImage) {
  auto rows = vgr::config::loadGraspTruth(dir_ + "/set/grasps.csv");
  ASSERT_TRUE(rows) << rows.error().message;
  std::set<std::string> images;
  for (const auto& r : *rows) images.insert(r.image);
  EXPECT_EQ(images.size(), 6u);
}

TEST_F(GraspCli, EvalScoresBothDetectorsOnTheSameImages) {
  const auto r = runVgr("eval --grasp --dataset " + dir_ + "/set --model " + kModel + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto j = nlohmann::json::parse(lastLine(r.out));
  EXPECT_EQ(j["images"], 6);
  for (const char* d : {"ggcnn", "analytic"}) {
    ASSERT_TRUE(j.contains(d)) << r.out;
    EXPECT_EQ(j[d]["graspable"], j["graspable"]);
    EXPECT_GE(j[d]["rect_success_rate"].get<double>(), 0);
    EXPECT_LE(j[d]["rect_success_rate"].get<double>(), 1);
    EXPECT_LE(j[d]["pos_success_rate"].get<double>(), j[d]["rect_success_rate"].get<double>());
    EXPECT_GT(j[d]["time_ms_median"].get<double>(), 0);
  }
  EXPECT_EQ(j["metric"]["min_iou"], 0.25);
  EXPECT_EQ(j["metric"]["max_angle_deg"], 30.0);
  EXPECT_EQ(j["metric"]["pos_tol_mm"], 2.0);
}

TEST_F(GraspCli, AnOnnxFileThatDoesNotLoadIsOneLineNamingIt) {
  const std::string bad = dir_ + "/broken.onnx";
  std::ofstream(bad) << "not a network";
  for (const std::string& args : {"eval --grasp --dataset " + dir_ + "/set --model " + bad,
                                 "grasp detect --dataset " + dir_ + "/set --model " + bad}) {
    const auto r = vgr::test::runCommand(vgr::test::binPath("vgr") + " " + args);
    EXPECT_EQ(r.exitCode, 2);
    EXPECT_EQ(r.err.rfind(bad + ": cannot load the grasp network: ", 0), 0u) << r.err;
    EXPECT_EQ(std::count(r.err.begin(), r.err.end(), '\n'), 1) << r.err;
    EXPECT_EQ(r.out, "");
  }
}

TEST_F(GraspCli, ADepthImageOfTheWrongSizeIsOneLineNamingIt) {
  fs::copy(dir_ + "/set", dir_ + "/small", fs::copy_options::recursive);
  cv::imwrite(dir_ + "/small/images/0002.png", cv::Mat(240, 320, CV_16UC1, cv::Scalar(5000)));
  for (const std::string& args : {"grasp detect --detector analytic --dataset " + dir_ + "/small",
                                 "eval --grasp --detectors analytic --dataset " + dir_ + "/small"}) {
    const auto r = vgr::test::runCommand(vgr::test::binPath("vgr") + " " + args);
    EXPECT_EQ(r.exitCode, 2) << args;
    EXPECT_EQ(r.err, dir_ + "/small/images/0002.png: 320x240 px, but camera.yaml says 640x480\n") << r.err;
  }
  const auto r = runVgr("eval --dataset " + dir_ + "/small");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("--job is required (or --grasp"), std::string::npos) << r.out;
}

TEST_F(GraspCli, GraspOptionsWithoutGraspAndJobOptionsWithGraspAreRefused) {
  // Each would be ignored by the other kind of evaluation: refused by name (exit 2), nothing run.
  const std::pair<std::string, std::string> cases[] = {
      {"eval --job " + dir_ + " --dataset " + dir_ + "/set --model " + kModel, "--model requires --grasp"},
      {"eval --job " + dir_ + " --dataset " + dir_ + "/set --min-iou 0.3", "--min-iou requires --grasp"},
      {"eval --grasp --detectors analytic --dataset " + dir_ + "/set --job " + dir_, "excludes --grasp"},
      {"eval --grasp --detectors analytic --dataset " + dir_ + "/set --pos-tol 3", "--pos-tol excludes --grasp"}};
  for (const auto& [args, why] : cases) {
    const auto r = runVgr(args);
    EXPECT_EQ(r.exitCode, 2) << args << "\n" << r.out;
    EXPECT_NE(r.out.find(why), std::string::npos) << args << "\n" << r.out;
    EXPECT_EQ(r.out.find("rect_success_rate"), std::string::npos) << args;
  }
}

TEST_F(GraspCli, DetectGivesGraspsInTheRobotFrameThroughTheThreeDCalibration) {
  // T_base_cam: the camera 700 mm above the base origin looking down, turned 30 deg.
  const double c = std::cos(M_PI / 6), s = std::sin(M_PI / 6);
  // rotation = Rz(30 deg) * diag(1, -1, -1) as a quaternion: 180 deg about (cos 15, sin 15, 0)
  const vgr::Pose x{100, -50, 700, 0, std::cos(M_PI / 12), std::sin(M_PI / 12), 0};
  const std::string he = dir_ + "/handeye.yaml";
  ASSERT_TRUE(vgr::vision::calib::writeHandEyeTruth(he, vgr::vision::calib::HandEyeConfig::EyeToHand, x, vgr::Pose{}));
  const auto r = runVgr("grasp detect --dataset " + dir_ + "/set --model " + kModel + " --camera-pose " + he);
  ASSERT_EQ(r.exitCode, 0) << r.out;
  int grasps = 0;
  std::istringstream lines(r.out);
  for (std::string line; std::getline(lines, line);) {
    const auto j = nlohmann::json::parse(line);
    for (const auto& g : j["grasps"]) {
      const double cx = g["camera"]["x_mm"], cy = g["camera"]["y_mm"], cz = g["camera"]["z_mm"];
      // base = Rz(30) * (cx, -cy, -cz) + (100, -50, 700)
      EXPECT_NEAR(g["robot"]["x_mm"].get<double>(), c * cx + s * cy + 100, 1e-3) << line;
      EXPECT_NEAR(g["robot"]["y_mm"].get<double>(), s * cx - c * cy - 50, 1e-3) << line;
      EXPECT_NEAR(g["robot"]["z_mm"].get<double>(), 700 - cz, 1e-3) << line;
      EXPECT_NEAR(g["robot"]["width_mm"].get<double>(), g["width_mm"].get<double>(), 0.05) << line;
      ++grasps;
    }
  }
  EXPECT_GE(grasps, 6);
}

TEST_F(GraspCli, APlaneCalibrationOfAnotherImageSizeIsRefused) {
  const std::string calib = vgr::test::sourcePath("config/examples/sim-calib");  // the 1280 x 1024 sim camera's
  const auto r = vgr::test::runCommand(vgr::test::binPath("vgr") + " grasp detect --detector analytic --dataset " + dir_ +
                                       "/set --intrinsics " + calib + "/intrinsics.yaml --handeye " + calib + "/handeye.yaml --plane " +
                                       calib + "/plane.yaml");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.err, calib + "/intrinsics.yaml: calibrated for 1280x1024 px images, the depth images are 640x480 (camera.yaml)\n");
  const auto partial = vgr::test::runCommand(vgr::test::binPath("vgr") + " grasp detect --detector analytic --dataset " + dir_ +
                                             "/set --plane " + calib + "/plane.yaml");
  EXPECT_EQ(partial.exitCode, 2);
  EXPECT_EQ(partial.err, "the plane calibration needs --intrinsics, --handeye and --plane together\n");
}

TEST_F(GraspCli, TensorsHoldTheNetworkInputAndFourTargetMaps) {
  const auto r = runVgr("grasp tensors --dataset " + dir_ + "/set --out " + dir_ + "/tensors --limit 2");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto j = nlohmann::json::parse(lastLine(r.out));
  EXPECT_EQ(j["rows"], 240);
  EXPECT_EQ(j["cols"], 324);
  // .npy: 128-byte header (64-byte aligned) + float16 data
  EXPECT_EQ(fs::file_size(dir_ + "/tensors/input.npy"), 128u + 2u * 1 * 240 * 324 * 2);
  EXPECT_EQ(fs::file_size(dir_ + "/tensors/target.npy"), 128u + 2u * 4 * 240 * 324 * 2);
  std::ifstream in(dir_ + "/tensors/input.npy", std::ios::binary);
  std::string head(128, '\0');
  in.read(head.data(), 128);
  EXPECT_EQ(head.substr(0, 6), "\x93NUMPY");
  EXPECT_NE(head.find("'descr': '<f2', 'fortran_order': False, 'shape': (2, 1, 240, 324,)"), std::string::npos) << head;
  const auto again = runVgr("grasp tensors --dataset " + dir_ + "/set --out " + dir_ + "/tensors");
  EXPECT_EQ(again.exitCode, 2) << "never overwrites";
}

}  // namespace
