// `vgr calibrate` end to end on rendered synthetic sets: intrinsics (--json contract),
// hand-eye from a folder of images + poses.txt, and the bad-input errors a user sees.
// No sockets: the real `vgr` binary on files in a temporary folder.
#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "tests/support/command.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/intrinsics.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/calib/se3.hpp"

namespace {

namespace fs = std::filesystem;

struct CmdRun {
  int rc = -1;
  std::string out;  // stdout + stderr
};

CmdRun vgr(const std::string& args) {
  const auto r = vgr::test::runVgr(args);
  return {r.exitCode, r.out};
}

using vgr::test::lastLine;

class calib_cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vgr-calib-cli-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }
  fs::path dir_;
};

TEST_F(calib_cli, intrinsics_then_handeye_on_rendered_sets) {
  const std::string intr = (dir_ / "intr").string(), he = (dir_ / "he").string();
  CmdRun s = vgr("calibrate synth --kind intrinsics --views 10 --out " + intr);
  ASSERT_EQ(s.rc, 0) << s.out;
  // A view in which the pattern is not there: reported by name, left out.
  cv::imwrite((dir_ / "intr" / "plate_blank.png").string(), cv::Mat(600, 800, CV_8UC1, cv::Scalar(120)));
  CmdRun r = vgr("calibrate intrinsics --images '" + intr + "/*.png' --pattern chessboard --cols 9 --rows 6 --square 20 --out " +
              intr + "/intrinsics.yaml --json");
  ASSERT_EQ(r.rc, 0) << r.out;
  EXPECT_NE(r.out.find("pattern not found, not used: plate_blank.png"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("11/11"), std::string::npos) << "progress per image";
  const auto j = nlohmann::json::parse(lastLine(r.out));
  for (const char* k : {"rms_px", "fx", "fy", "cx", "cy", "views_used"}) EXPECT_TRUE(j.contains(k)) << k;
  EXPECT_EQ(j["views_used"].get<int>(), 10);
  EXPECT_LT(j["rms_px"].get<double>(), 0.2);
  EXPECT_NEAR(j["fx"].get<double>(), 900.0, 9.0);  // 10 views: a pipeline check, not the accuracy bound
  auto file = vgr::vision::calib::readIntrinsics(intr + "/intrinsics.yaml");
  ASSERT_TRUE(file) << file.error().message;
  EXPECT_DOUBLE_EQ(file->fx(), j["fx"].get<double>());

  s = vgr("calibrate synth --kind handeye --configuration eye-to-hand --pose-format ur --views 10 --out " + he);
  ASSERT_EQ(s.rc, 0) << s.out;
  r = vgr("calibrate handeye --folder " + he + " --intrinsics " + intr +
          "/intrinsics.yaml --cols 9 --rows 6 --square 20 --truth " + he + "/truth.yaml --out " + he + "/handeye.yaml --json");
  ASSERT_EQ(r.rc, 0) << r.out;
  const auto h = nlohmann::json::parse(lastLine(r.out));
  EXPECT_EQ(h["configuration"], "eye-to-hand");  // found by auto
  EXPECT_EQ(h["methods"].size(), 10u);
  for (const auto& m : h["methods"])  // the shared method table (printHandEyeMethods): fit column and truth error
    EXPECT_TRUE(m.contains("reproj_px") && m.contains("err_x_mm") && m.contains("err_x_deg")) << m.dump();
  auto heFile = vgr::vision::calib::readHandEye(he + "/handeye.yaml");
  auto truth = vgr::vision::calib::readHandEye(he + "/truth.yaml");
  ASSERT_TRUE(heFile && truth);
  namespace se3 = vgr::vision::se3;
  const se3::Iso d = se3::toIso(truth->x).inverse() * se3::toIso(heFile->x);
  EXPECT_LT(d.translation().norm(), 1.0);  // 10 rendered views, estimated intrinsics
  EXPECT_LT(se3::rotationAngleDeg(d.linear()), 0.1);

  // Work plane from the plate lying on the conveyor (z = 0), then the files vgrd would load:
  // points on the belt and 25 mm above it map back within half a millimetre (rendered
  // images, 10 views each, every parameter estimated).
  r = vgr("calibrate plane --image " + he + "/plane/conveyor_plate.png --intrinsics " + intr +
          "/intrinsics.yaml --handeye " + he + "/handeye.yaml --out " + he + "/plane.yaml --json");
  ASSERT_EQ(r.rc, 0) << r.out;
  auto mapping = vgr::vision::calib::loadCellCalibration(intr + "/intrinsics.yaml", he + "/handeye.yaml", he + "/plane.yaml");
  ASSERT_TRUE(mapping) << mapping.error().message;
  const vgr::vision::calib::CameraPlaneMapping trueMap(*vgr::vision::calib::readIntrinsics(he + "/camera_truth.yaml"),
                                                      truth->x, vgr::vision::calib::WorkPlane{});
  double worst = 0;
  for (double height : {0.0, 25.0})
    for (double x = 250; x <= 550; x += 50)
      for (double y = -200; y <= 200; y += 50) {
        const auto px = trueMap.robotToPixel({x, y, height});
        ASSERT_TRUE(px);
        if (px->u < 0 || px->v < 0 || px->u > 799 || px->v > 599) continue;
        const auto got = mapping->pixelToRobot(*px, height);
        ASSERT_TRUE(got);
        worst = std::max(worst, std::hypot(got->x - x, got->y - y));
      }
  std::printf("rendered-set mapping: worst error %.3f mm at h = 0 and 25 mm\n", worst);
  EXPECT_LT(worst, 0.5);

  // An image without a pose: the count mismatch names it.
  fs::copy_file(he + "/pose_000.png", he + "/extra.png");
  r = vgr("calibrate handeye --folder " + he + " --intrinsics " + intr + "/intrinsics.yaml --out " + he + "/x.yaml");
  EXPECT_EQ(r.rc, 2);
  EXPECT_NE(r.out.find("without a pose: extra.png"), std::string::npos) << r.out;
  fs::remove(he + "/extra.png");
  // A pose whose image is missing: named with file and line.
  fs::remove(he + "/pose_003.png");
  r = vgr("calibrate handeye --folder " + he + " --intrinsics " + intr + "/intrinsics.yaml --out " + he + "/x.yaml");
  EXPECT_EQ(r.rc, 2);
  EXPECT_NE(r.out.find("poses.txt:7: image 'pose_003.png' cannot be read"), std::string::npos) << r.out;
}

TEST_F(calib_cli, too_few_views_and_no_images_are_clear_errors) {
  for (int i = 0; i < 3; ++i)
    cv::imwrite((dir_ / ("blank" + std::to_string(i) + ".png")).string(), cv::Mat(480, 640, CV_8UC1, cv::Scalar(90)));
  CmdRun r = vgr("calibrate intrinsics --images '" + dir_.string() + "/*.png' --out " + (dir_ / "i.yaml").string());
  EXPECT_EQ(r.rc, 2);
  EXPECT_NE(r.out.find("too few views"), std::string::npos) << r.out;
  EXPECT_NE(r.out.find("blank0.png, blank1.png, blank2.png"), std::string::npos) << r.out;
  r = vgr("calibrate intrinsics --images '" + dir_.string() + "/none*.png'");
  EXPECT_EQ(r.rc, 2);
  EXPECT_NE(r.out.find("no file matches"), std::string::npos) << r.out;
  r = vgr("calibrate intrinsics --images '" + dir_.string() + "/*.png' --pattern hexagons");
  EXPECT_EQ(r.rc, 2);
  EXPECT_NE(r.out.find("unknown pattern 'hexagons'"), std::string::npos) << r.out;
}

}  // namespace
