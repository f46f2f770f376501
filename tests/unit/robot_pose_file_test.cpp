// The robot pose file (vision/calib/robot_pose_file.hpp): what `vgr calibrate synth` writes,
// `vgr calibrate handeye` reads back, in each controller's convention.
#include <cmath>
#include <filesystem>
#include <string>

#include <unistd.h>

#include <gtest/gtest.h>

#include "core/pose.hpp"
#include "vision/calib/robot_pose_file.hpp"

namespace {

namespace calib = vgr::vision::calib;

double angleBetweenDeg(const vgr::Pose& a, const vgr::Pose& b) {
  const double dot = std::abs(a.qw * b.qw + a.qx * b.qx + a.qy * b.qy + a.qz * b.qz);
  return 2 * std::acos(std::min(1.0, dot)) * 180 / M_PI;
}

TEST(robot_pose_file, WrittenFilesReadBackInEveryFormat) {
  const std::vector<calib::PoseEntry> poses = {
      {"pose_000.png", vgr::poseFromXyzRz(400, -20, 300, 0.3), 0},
      {"pose_001.png", vgr::poseFromXyzRz(-12.5, 610.25, 95, -2.9), 0}};
  const std::string path =
      (std::filesystem::temp_directory_path() / ("vgr-poses-" + std::to_string(::getpid()) + ".txt")).string();
  for (const char* format : {"abb", "fanuc", "ur"}) {
    ASSERT_TRUE(calib::writePoseFile(path, format, poses).has_value()) << format;
    auto back = calib::loadPoseFile(path);
    ASSERT_TRUE(back.has_value()) << format << ": " << back.error().message;
    ASSERT_EQ(back->size(), poses.size());
    for (std::size_t i = 0; i < poses.size(); ++i) {
      const auto& p = poses[i].baseFromGripper;
      const auto& q = (*back)[i].baseFromGripper;
      EXPECT_EQ((*back)[i].image, poses[i].image);
      EXPECT_EQ((*back)[i].line, static_cast<int>(i) + 4) << format;  // after the comment, format and units lines
      EXPECT_LT(std::hypot(p.x - q.x, p.y - q.y, p.z - q.z), 1e-3) << format;
      EXPECT_LT(angleBetweenDeg(p, q), 1e-4) << format;
    }
  }
  std::filesystem::remove(path);
  EXPECT_FALSE(calib::poseFileText("kuka", poses).has_value());
}

}  // namespace
