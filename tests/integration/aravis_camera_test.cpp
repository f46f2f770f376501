// The real Aravis driver against the camera emulator over loopback GigE Vision: frames
// arrive, carry the emulator's frame ids, and show the part where the renderer put it.
#include <cmath>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "config/cell_config.hpp"
#include "daemon/camera_worker.hpp"
#include "daemon/process.hpp"
#include "drivers/camera.hpp"
#include "sim/scene.hpp"
#include "vision/locate/moments_locator.hpp"

namespace {

using std::chrono::milliseconds;
using vgr::daemon::ChildProcess;

vgr::config::CellConfig simCell() {
  auto cfg = vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
  EXPECT_TRUE(cfg.has_value());
  return *cfg;
}

ChildProcess startEmulator(std::uint64_t seed) {
  auto p = ChildProcess::spawn({std::string(VGR_BIN_DIR) + "/vgr-sim-camera", "--seed", std::to_string(seed)});
  EXPECT_TRUE(p.has_value());
  EXPECT_TRUE(p->waitForLine("\"ready\"", milliseconds(5000)));
  return std::move(*p);
}

TEST(AravisCamera, FramesMatchGroundTruth) {
  const auto cfg = simCell();
  auto emulator = startEmulator(11);
  auto cam = vgr::drivers::makeCamera(cfg.camera);
  ASSERT_TRUE(cam.has_value());
  auto& camera = **cam;
  ASSERT_TRUE(camera.open()) << camera.describe();
  EXPECT_EQ(camera.state(), vgr::drivers::CameraState::Open);
  ASSERT_TRUE(camera.start());
  EXPECT_EQ(camera.state(), vgr::drivers::CameraState::Streaming);

  auto cell = cfg;
  cell.sim.seed = 11;
  const auto renderer = vgr::sim::SceneRenderer::fromCellConfig(cell);
  vgr::drivers::Frame frame;
  std::uint64_t lastId = 0;
  for (int i = 0; i < 10; ++i) {
    auto r = camera.triggerAndWait(frame, milliseconds(2000));
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(frame.width, cfg.sim.width);
    EXPECT_EQ(frame.height, cfg.sim.height);
    EXPECT_GT(frame.frameId, lastId);
    lastId = frame.frameId;
    // The GigE path delivers the rendered image byte for byte.
    cv::Mat expected;
    renderer.render(frame.frameId, expected);
    const cv::Mat got(frame.height, frame.width, CV_8UC1, frame.data.data());
    EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0.0) << "frame " << frame.frameId;
    auto found = vgr::vision::locateByMoments(got, {});
    ASSERT_TRUE(found && found->size() == 1);
    const auto truth = renderer.truthForFrame(frame.frameId);
    EXPECT_LT(std::hypot(found->front().u - truth.uPx, found->front().v - truth.vPx), 0.2);
  }
  camera.stop();
  EXPECT_EQ(camera.state(), vgr::drivers::CameraState::Open);
  camera.close();
  EXPECT_EQ(camera.state(), vgr::drivers::CameraState::Closed);
}

TEST(AravisCamera, IllegalTransitionsAreErrors) {
  const auto cfg = simCell();
  auto emulator = startEmulator(1);
  auto cam = vgr::drivers::makeCamera(cfg.camera);
  ASSERT_TRUE(cam.has_value());
  auto& camera = **cam;
  vgr::drivers::Frame frame;
  EXPECT_FALSE(camera.start());                                    // Closed -> Streaming
  EXPECT_FALSE(camera.triggerAndWait(frame, milliseconds(100)));  // not streaming
  ASSERT_TRUE(camera.open());
  EXPECT_FALSE(camera.open());                                     // Open -> Open
  EXPECT_FALSE(camera.triggerAndWait(frame, milliseconds(100)));
}

TEST(AravisCamera, NoCameraIsAClearError) {
  auto cfg = simCell();
  cfg.camera.address = "127.0.0.3";  // nobody serves there
  auto cam = vgr::drivers::makeCamera(cfg.camera);
  ASSERT_TRUE(cam.has_value());
  auto r = (*cam)->open();
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, vgr::Status::CameraError);
  EXPECT_NE(r.error().message.find("127.0.0.3"), std::string::npos) << r.error().message;
}

TEST(CameraWorker, ReconnectsAfterTheCameraComesBack) {
  auto cfg = simCell();
  auto emulator = startEmulator(1);
  auto cam = vgr::drivers::makeCamera(cfg.camera);
  ASSERT_TRUE(cam.has_value());
  vgr::daemon::CameraWorker worker(cfg.camera, std::move(*cam));
  worker.start();
  ASSERT_TRUE(worker.waitStreaming(milliseconds(5000)));
  vgr::drivers::Frame frame;
  auto deadline = [] { return std::chrono::steady_clock::now() + milliseconds(1350); };
  ASSERT_TRUE(worker.grab(frame, deadline()));

  emulator.kill9();
  // Every grab ends by its deadline with a camera error while the camera is gone.
  for (int i = 0; i < 3; ++i) {
    const auto t0 = std::chrono::steady_clock::now();
    auto r = worker.grab(frame, deadline());
    const auto took = std::chrono::steady_clock::now() - t0;
    EXPECT_FALSE(r);
    if (!r) {
      EXPECT_EQ(r.error().code, vgr::Status::CameraError);
    }
    EXPECT_LT(took, milliseconds(1450));
  }

  emulator = startEmulator(1);
  const auto back = std::chrono::steady_clock::now();
  bool ok = false;
  while (std::chrono::steady_clock::now() - back < std::chrono::seconds(15) && !ok) {
    ok = worker.grab(frame, deadline()).has_value();
    if (!ok) std::this_thread::sleep_for(milliseconds(100));
  }
  EXPECT_TRUE(ok) << "no frame within 15 s of the camera's return";
  EXPECT_GE(worker.counters().reconnects, 1u);
  worker.stop();
}

}  // namespace
