#include "tests/support/depth_dataset.hpp"

#include <filesystem>

#include <fmt/format.h>
#include <gtest/gtest.h>
#include <opencv2/imgcodecs.hpp>

#include "config/depth_dataset.hpp"
#include "sim/calib_scene.hpp"
#include "sim/depth_calib_scene.hpp"

namespace vgr::test {

DepthTestSet writeDepthTestSet(const std::string& dir, int images, unsigned seed, bool withEmpty) {
  namespace fs = std::filesystem;
  DepthTestSet set;
  set.dir = dir;
  const auto cam = sim::defaultDepthCamera();
  set.width = cam.width;
  set.height = cam.height;
  set.depthScaleMm = cam.depthScaleMm;
  fs::create_directories(fs::path(dir) / "images");
  config::DepthCameraFile file;
  file.width = cam.width;
  file.height = cam.height;
  file.setIntrinsics(cam.intrinsics);
  file.depthScaleMm = cam.depthScaleMm;
  EXPECT_TRUE(config::writeDepthCameraFile((fs::path(dir) / "camera.yaml").string(), file));
  sim::TrueCamera plateCam;
  plateCam.cameraMatrix = cv::Matx33d(cam.intrinsics.fx, 0, cam.intrinsics.cx, 0, cam.intrinsics.fy, cam.intrinsics.cy, 0, 0, 1);
  plateCam.imageSize = cv::Size(cam.width, cam.height);
  const auto target = sim::defaultSphereTarget();
  const auto poses = sim::randomPlateViews(plateCam, sim::sphereTargetFootprint(), images, seed, 450, 30);
  std::vector<config::DepthTruthRow> rows;
  for (int i = 0; i < images; ++i) {
    const std::string name = fmt::format("images/{:04d}.png", i);
    const bool empty = withEmpty && i == images - 1;
    sim::DepthRenderOptions o;
    o.seed = seed * 100 + static_cast<unsigned>(i);
    vision::calib::SphereTarget shown = target;
    if (empty) shown.centres.clear();  // the plate alone
    const cv::Mat depth = sim::renderSphereTargetDepth(cam, shown, sim::sphereTargetFootprint(), poses[static_cast<std::size_t>(i)], o);
    EXPECT_TRUE(cv::imwrite((fs::path(dir) / name).string(), sim::quantiseDepth(depth, cam.depthScaleMm)));
    set.images.push_back(name);
    set.truth.push_back(empty ? std::vector<Pose>{} : std::vector<Pose>{poses[static_cast<std::size_t>(i)]});
    rows.push_back({name, !empty, empty ? Pose{} : poses[static_cast<std::size_t>(i)], 0});
  }
  EXPECT_TRUE(config::writeDepthTruth((fs::path(dir) / "truth.csv").string(), rows));
  return set;
}

}  // namespace vgr::test
