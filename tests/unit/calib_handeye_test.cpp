// Hand-eye on synthetic robot poses and plate corners (sim/calib_scene) in both
// configurations: accuracy of the refined result against the truth, method checks, degenerate
// pose sets, configuration mix-ups and the pose file formats.
#include <cmath>
#include <filesystem>

#include <gtest/gtest.h>

#include "sim/calib_scene.hpp"
#include "vision/calib/handeye.hpp"
#include "vision/calib/se3.hpp"

namespace {

using namespace vgr;
using vision::calib::HandEyeConfig;
using vision::calib::PatternKind;
using vision::calib::PatternSpec;
namespace se3 = vision::se3;

const PatternSpec kSpec{PatternKind::Chessboard, 9, 6, 20.0};

struct Data {
  sim::HandEyeScenario truth;
  std::vector<vision::calib::HandEyeView> views;
  vision::calib::CameraIntrinsics cam;
};

Data makeData(HandEyeConfig cfg, int n, double cornerSigma, double robotMm, double robotDeg, std::uint64_t seed) {
  Data d;
  const auto cam = sim::defaultCalibCamera();
  d.cam.cameraMatrix = cam.cameraMatrix;
  d.cam.dist = cam.dist;
  d.cam.imageSize = cam.imageSize;
  d.truth = sim::makeHandEyeScenario(cfg, cam, kSpec, n, seed, robotMm, robotDeg);
  for (std::size_t i = 0; i < d.truth.camFromPlate.size(); ++i)
    d.views.push_back({"pose" + std::to_string(i), d.truth.robotReported[i],
                       sim::addCornerNoise(sim::projectPattern(cam, kSpec, d.truth.camFromPlate[i]), cornerSigma,
                                           seed * 1000 + i)});
  return d;
}

void poseError(const Pose& a, const Pose& b, double& mm, double& deg) {
  const se3::Iso d = se3::toIso(a).inverse() * se3::toIso(b);
  mm = d.translation().norm();
  deg = se3::rotationAngleDeg(d.linear());
}

// The accuracy target of docs/calibration.md: 15 poses, 0.2 px corners, 0.05 mm / 0.01 deg robot noise, both
// configurations: the refined result within 0.5 mm and 0.05 deg of the truth.
class calib_handeye_accuracy : public ::testing::TestWithParam<HandEyeConfig> {};

TEST_P(calib_handeye_accuracy, refined_result_within_half_a_millimetre_and_0p05_deg) {
  for (std::uint64_t seed : {1, 2, 3}) {
  SCOPED_TRACE(seed);
  const Data d = makeData(GetParam(), 15, 0.2, 0.05, 0.01, seed);
  ASSERT_EQ(d.views.size(), 15u);
  auto r = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, GetParam());
  ASSERT_TRUE(r) << r.error().message;
  const auto& refined = *std::find_if(r->methods.begin(), r->methods.end(), [](auto& m) { return m.method == "refined"; });
  ASSERT_TRUE(refined.valid) << refined.note;
  double mm, deg;
  poseError(refined.x, d.truth.x, mm, deg);
  EXPECT_LT(mm, 0.5);
  EXPECT_LT(deg, 0.05);
  poseError(refined.y, d.truth.y, mm, deg);
  EXPECT_LT(mm, 0.5);
  EXPECT_LT(deg, 0.05);
  // Every OpenCV method ran and was checked; the winner is a consistent one.
  EXPECT_GE(r->methods.size(), 9u);
  EXPECT_TRUE(r->bestResult().valid);
  EXPECT_FALSE(r->reason.empty());
  EXPECT_LT(r->bestResult().reprojRmsPx, 0.5);
  EXPECT_EQ(r->bestResult().method, "refined");
  }
}

TEST_P(calib_handeye_accuracy, noise_free_data_is_recovered_exactly) {
  const Data d = makeData(GetParam(), 8, 0.0, 0.0, 0.0, 2);
  auto r = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, GetParam());
  ASSERT_TRUE(r) << r.error().message;
  for (const auto& m : r->methods) {
    if (!m.valid) continue;
    double mm, deg;
    poseError(m.x, d.truth.x, mm, deg);
    EXPECT_LT(mm, 0.05) << m.method;
    EXPECT_LT(deg, 0.005) << m.method;
  }
}

INSTANTIATE_TEST_SUITE_P(both, calib_handeye_accuracy,
                         ::testing::Values(HandEyeConfig::EyeInHand, HandEyeConfig::EyeToHand),
                         [](const auto& p) { return p.param == HandEyeConfig::EyeInHand ? "eye_in_hand" : "eye_to_hand"; });

TEST(calib_handeye, swapped_configuration_is_detected_by_auto) {
  const Data d = makeData(HandEyeConfig::EyeToHand, 12, 0.2, 0.05, 0.01, 3);
  auto r = vision::calib::calibrateHandEyeAuto(d.views, d.cam, kSpec);
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->config, HandEyeConfig::EyeToHand);
  // Forced into the wrong configuration, every method is rejected (no silent NaN or garbage).
  auto wrong = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, HandEyeConfig::EyeInHand);
  if (wrong) {
    EXPECT_GT(wrong->bestResult().reprojRmsPx, 5 * r->bestResult().reprojRmsPx);
  } else {
    EXPECT_NE(wrong.error().message.find("no method gave a consistent result"), std::string::npos)
        << wrong.error().message;
  }
}

TEST(calib_handeye, too_few_views_is_an_error) {
  Data d = makeData(HandEyeConfig::EyeInHand, 2, 0.0, 0, 0, 4);
  auto r = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, HandEyeConfig::EyeInHand);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("too few views"), std::string::npos) << r.error().message;
}

TEST(calib_handeye, corner_count_mismatch_names_the_view) {
  Data d = makeData(HandEyeConfig::EyeInHand, 6, 0.0, 0, 0, 5);
  d.views[4].corners.resize(20);
  auto r = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, HandEyeConfig::EyeInHand);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("pose4"), std::string::npos) << r.error().message;
}

TEST(calib_handeye, pure_translation_is_degenerate_and_names_the_views) {
  // The robot only translates: the rotation part of AX = XB is unobservable.
  const auto cam = sim::defaultCalibCamera();
  Data d = makeData(HandEyeConfig::EyeToHand, 1, 0.0, 0, 0, 6);
  const se3::Iso x = se3::toIso(d.truth.x), y = se3::toIso(d.truth.y);
  const se3::Iso a0 = se3::toIso(d.truth.robotTrue[0]);
  d.views.clear();
  for (int i = 0; i < 5; ++i) {
    se3::Iso a = a0;
    a.translation() += Eigen::Vector3d(15.0 * i, -10.0 * i, 5.0 * (i % 2));
    const se3::Iso b = x.inverse() * a * y;  // T_cam_target
    d.views.push_back({"move" + std::to_string(i), se3::toPose(a), sim::projectPattern(cam, kSpec, se3::toPose(b))});
  }
  auto r = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, HandEyeConfig::EyeToHand);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("degenerate motion"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("move0"), std::string::npos) << r.error().message;
}

TEST(calib_handeye, rotation_about_a_single_axis_is_degenerate) {
  const auto cam = sim::defaultCalibCamera();
  Data d = makeData(HandEyeConfig::EyeToHand, 1, 0.0, 0, 0, 7);
  const se3::Iso x = se3::toIso(d.truth.x), y = se3::toIso(d.truth.y);
  const se3::Iso a0 = se3::toIso(d.truth.robotTrue[0]);
  d.views.clear();
  for (int i = 0; i < 5; ++i) {
    se3::Iso a = a0;
    a.linear() = a0.linear() * Eigen::AngleAxisd(0.1 * i, Eigen::Vector3d::UnitZ()).toRotationMatrix();
    const se3::Iso b = x.inverse() * a * y;
    d.views.push_back({"turn" + std::to_string(i), se3::toPose(a), sim::projectPattern(cam, kSpec, se3::toPose(b))});
  }
  auto r = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, HandEyeConfig::EyeToHand);
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("same axis"), std::string::npos) << r.error().message;
}

TEST(calib_handeye, duplicate_poses_are_warned_about_by_name) {
  Data d = makeData(HandEyeConfig::EyeInHand, 8, 0.1, 0, 0, 8);
  d.views.push_back(d.views[3]);
  d.views.back().name = "again3";
  auto r = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, HandEyeConfig::EyeInHand);
  ASSERT_TRUE(r) << r.error().message;
  bool seen = false;
  for (const auto& w : r->warnings) seen |= w.find("pose3") != std::string::npos && w.find("again3") != std::string::npos;
  EXPECT_TRUE(seen);
}

TEST(calib_handeye, pose_file_formats_agree) {
  // One pose, three brands: ABB quaternion in mm, FANUC W,P,R in mm, UR rotation vector in m.
  const Pose p = se3::toPose(se3::Iso(Eigen::Translation3d(400, -20, 300) *
                                      Eigen::AngleAxisd(0.7, Eigen::Vector3d(0.2, -0.5, 1).normalized())));
  const EulerZyxDeg e = toEulerZyxDeg(p);
  const Vec3 rv = toRotationVector(p);
  const std::string text =
      "format abb\nunits mm\n"
      "a.png 400 -20 300 " + std::to_string(p.qw) + " " + std::to_string(p.qx) + " " + std::to_string(p.qy) + " " +
      std::to_string(p.qz) + "\n";
  const std::string fanuc = "format fanuc  # W P R\nunits mm\nb.png 400 -20 300 " + std::to_string(e.rx) + " " +
                            std::to_string(e.ry) + " " + std::to_string(e.rz) + "\n";
  const std::string ur = "format ur\nunits m\nc.png 0.4 -0.02 0.3 " + std::to_string(rv.x) + " " +
                         std::to_string(rv.y) + " " + std::to_string(rv.z) + "\n";
  for (const auto& t : {text, fanuc, ur}) {
    auto r = vision::calib::parsePoseFile(t, "poses.txt");
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_EQ(r->size(), 1u);
    double mm, deg;
    poseError((*r)[0].baseFromGripper, p, mm, deg);
    EXPECT_LT(mm, 1e-6) << t;
    EXPECT_LT(deg, 1e-4) << t;
  }
}

TEST(calib_handeye, pose_file_errors_name_file_and_line) {
  auto r = vision::calib::parsePoseFile("format abb\nunits mm\na.png 1 2 3 1 0 0\n", "poses.txt");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("poses.txt:3"), std::string::npos) << r.error().message;
  r = vision::calib::parsePoseFile("format kuka\n", "poses.txt");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("poses.txt:1"), std::string::npos) << r.error().message;
  r = vision::calib::parsePoseFile("a.png 1 2 3 0 0 0\n", "p.txt");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("p.txt:1"), std::string::npos) << r.error().message;
  r = vision::calib::parsePoseFile("format ur\nunits m\na.png 1 2 x 0 0 0\n", "p.txt");
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("'x'"), std::string::npos) << r.error().message;
}

TEST(calib_handeye, yaml_round_trip) {
  const Data d = makeData(HandEyeConfig::EyeToHand, 8, 0.1, 0, 0, 9);
  auto r = vision::calib::calibrateHandEye(d.views, d.cam, kSpec, HandEyeConfig::EyeToHand);
  ASSERT_TRUE(r) << r.error().message;
  const auto path = std::filesystem::temp_directory_path() / ("vgr-handeye-" + std::to_string(::getpid()) + ".yaml");
  ASSERT_TRUE(vision::calib::writeHandEye(path.string(), *r));
  auto back = vision::calib::readHandEye(path.string());
  ASSERT_TRUE(back) << back.error().message;
  EXPECT_EQ(back->config, HandEyeConfig::EyeToHand);
  EXPECT_EQ(back->method, r->bestResult().method);
  double mm, deg;
  poseError(back->x, r->bestResult().x, mm, deg);
  EXPECT_LT(mm, 1e-9);
  EXPECT_NEAR(back->reprojRmsPx, r->bestResult().reprojRmsPx, 1e-12);
  std::filesystem::remove(path);
}

}  // namespace
