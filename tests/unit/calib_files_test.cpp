// The cell's calibration files: the `calibration` config section and the checks vgrd runs
// before mapping with them (missing / malformed / eye-in-hand / residuals above the limits
// -> NOT_CALIBRATED naming the file and why).
#include <cstdio>
#include <filesystem>
#include <fstream>

#include <gtest/gtest.h>

#include "config/cell_config.hpp"
#include "sim/calib_scene.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/se3.hpp"

namespace {

using namespace vgr;
namespace calib = vision::calib;
namespace fs = std::filesystem;

class calib_files : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vgr-calib-files-" + std::to_string(::getpid()));
    fs::create_directories(dir_);
    // Good files: the true camera, an eye-to-hand result, the conveyor plane z = 0.
    const auto cam = sim::defaultCalibCamera();
    calib::CameraIntrinsics ci;
    ci.cameraMatrix = cam.cameraMatrix;
    ci.dist = cam.dist;
    ci.imageSize = cam.imageSize;
    ci.rmsPx = 0.1;
    ASSERT_TRUE(calib::writeIntrinsics(path("intrinsics.yaml"), ci));
    const calib::PatternSpec spec{calib::PatternKind::Chessboard, 9, 6, 20};
    truth_ = sim::makeHandEyeScenario(calib::HandEyeConfig::EyeToHand, cam, spec, 8, 3, 0, 0);
    std::vector<calib::HandEyeView> views;
    for (std::size_t i = 0; i < truth_.camFromPlate.size(); ++i)
      views.push_back({"pose" + std::to_string(i), truth_.robotReported[i], sim::projectPattern(cam, spec, truth_.camFromPlate[i])});
    auto he = calib::calibrateHandEye(views, ci, spec, calib::HandEyeConfig::EyeToHand);
    ASSERT_TRUE(he) << he.error().message;
    handEye_ = *he;
    ASSERT_TRUE(calib::writeHandEye(path("handeye.yaml"), handEye_));
    ASSERT_TRUE(calib::writeWorkPlane(path("plane.yaml"), calib::WorkPlane{{0, 0, 0}, {0, 0, 1}, 0}, "points"));
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::string path(const std::string& n) const { return (dir_ / n).string(); }
  void write(const std::string& n, const std::string& text) const { std::ofstream(dir_ / n) << text; }
  fs::path dir_;
  sim::HandEyeScenario truth_;
  calib::HandEyeResult handEye_;
};

TEST_F(calib_files, good_files_map_like_the_truth) {
  auto m = calib::loadCellCalibration(path("intrinsics.yaml"), path("handeye.yaml"), path("plane.yaml"));
  ASSERT_TRUE(m) << m.error().message;
  const Vec3 p{380, -40, 25};
  const auto px = m->robotToPixel(p);
  ASSERT_TRUE(px);
  const auto back = m->pixelToRobot(*px, 25);
  ASSERT_TRUE(back);
  EXPECT_NEAR(back->x, 380, 1e-6);
  EXPECT_NEAR(back->y, -40, 1e-6);
  EXPECT_NEAR(back->z, 25, 1e-6);
}

TEST_F(calib_files, each_bad_file_is_named_with_the_reason) {
  auto m = calib::loadCellCalibration(path("nope.yaml"), path("handeye.yaml"), path("plane.yaml"));
  ASSERT_FALSE(m);
  EXPECT_EQ(m.error().code, Status::NotCalibrated);
  EXPECT_NE(m.error().message.find("nope.yaml"), std::string::npos) << m.error().message;

  write("plane_bad.yaml", "%YAML:1.0\n---\npoint_mm: [0, 0, 0]\n");
  m = calib::loadCellCalibration(path("intrinsics.yaml"), path("handeye.yaml"), path("plane_bad.yaml"));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("plane_bad.yaml: keys 'point_mm' and 'normal'"), std::string::npos) << m.error().message;

  // Text that is no map of keys (fuzz_calib_files: OpenCV's parser looped without end on
  // it; it must be refused before OpenCV sees it, fast, with the reason).
  write("plane_not_a_map.yaml", "%YAML:1.0\n  -ion^ ]/\n. ]\n  -ion^ ]/\n");
  m = calib::loadCellCalibration(path("intrinsics.yaml"), path("handeye.yaml"), path("plane_not_a_map.yaml"));
  ASSERT_FALSE(m);
  EXPECT_EQ(m.error().code, Status::NotCalibrated);
  EXPECT_NE(m.error().message.find("top level is not a map"), std::string::npos) << m.error().message;

  // Residuals the hand-eye file was accepted with, above the limits: inconsistent.
  calib::HandEyeResult worse = handEye_;
  worse.methods[static_cast<std::size_t>(worse.best)].transResidMm = 5.0;
  ASSERT_TRUE(calib::writeHandEye(path("handeye_bad.yaml"), worse));
  m = calib::loadCellCalibration(path("intrinsics.yaml"), path("handeye_bad.yaml"), path("plane.yaml"));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("handeye_bad.yaml: residuals"), std::string::npos) << m.error().message;

  // An eye-in-hand file for a fixed camera.
  calib::HandEyeResult ih = handEye_;
  ih.config = calib::HandEyeConfig::EyeInHand;
  ASSERT_TRUE(calib::writeHandEye(path("handeye_ih.yaml"), ih));
  m = calib::loadCellCalibration(path("intrinsics.yaml"), path("handeye_ih.yaml"), path("plane.yaml"));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("eye-in-hand"), std::string::npos) << m.error().message;

  // A plane behind the camera: files from different cells.
  ASSERT_TRUE(calib::writeWorkPlane(path("plane_far.yaml"), calib::WorkPlane{{0, 0, 5000}, {0, 0, 1}, 0}, "points"));
  m = calib::loadCellCalibration(path("intrinsics.yaml"), path("handeye.yaml"), path("plane_far.yaml"));
  ASSERT_FALSE(m);
  EXPECT_NE(m.error().message.find("behind the camera"), std::string::npos) << m.error().message;
}

TEST_F(calib_files, config_section_paths_are_relative_to_the_config) {
  // The example cell without its own `calibration` section.
  std::string base = config::embeddedSimCellYaml();
  const auto from = base.find("\ncalibration:\n"), to = base.find("\nmodbus:");
  ASSERT_TRUE(from != std::string::npos && to != std::string::npos);
  base.erase(from, to - from);
  std::string yaml = base;
  yaml += "\ncalibration:\n  intrinsics: intrinsics.yaml\n  handeye: /abs/handeye.yaml\n  plane: sub/plane.yaml\n";
  auto c = config::parseCellConfig(yaml, path("cell.yaml"));
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_TRUE(c->calibration.enabled);
  EXPECT_EQ(c->calibration.intrinsics, path("intrinsics.yaml"));
  EXPECT_EQ(c->calibration.handeye, "/abs/handeye.yaml");
  EXPECT_EQ(c->calibration.plane, path("sub/plane.yaml"));
  // A missing key is named with file and line.
  std::string partial = base + "\ncalibration:\n  intrinsics: i.yaml\n  plane: p.yaml\n";
  auto bad = config::parseCellConfig(partial, "cell.yaml");
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("calibration.handeye"), std::string::npos) << bad.error().message;
  // Without the section: the `model` mapping, as before.
  auto none = config::parseCellConfig(base, "cell.yaml");
  ASSERT_TRUE(none);
  EXPECT_FALSE(none->calibration.enabled);
  // The example cell maps with its calibration files, next to it.
  auto example = config::parseCellConfig(config::embeddedSimCellYaml(), path("cell.yaml"));
  ASSERT_TRUE(example);
  EXPECT_TRUE(example->calibration.enabled);
  EXPECT_EQ(example->calibration.handeye, path("sim-calib/handeye.yaml"));
}

}  // namespace
