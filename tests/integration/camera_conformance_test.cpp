// The Camera conformance suite: every Camera implementation passes the same behavioural
// tests against a real device. "aravis" is the real Aravis driver against the GigE camera
// emulator (vgr-sim-camera, a separate process, over loopback GVCP/GVSP); "replay" is the
// replay camera over a folder of PNG files. "aravis_depth" is the same driver with
// pixel_format Coord3D_C16 against the emulator as a depth camera (--depth: Coord3D_C16 over
// real GVSP, the Scan3d features read from it), "replay_depth" the replay camera over the
// same 3D data set. Adding a driver = adding a Device below.
#include <signal.h>
#include <unistd.h>

#include <chrono>
#include <filesystem>
#include <memory>
#include <string>
#include <thread>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "drivers/camera.hpp"
#include "sim/scene.hpp"
#include "tests/support/depth_dataset.hpp"
#include "tests/support/processes.hpp"

namespace {

namespace fs = std::filesystem;
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;
using vgr::test::ChildProcess;
using vgr::drivers::CameraState;
using vgr::drivers::FrameStatus;

vgr::config::CellConfig simCell() {
  auto cfg = vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
  EXPECT_TRUE(cfg.has_value());
  return *cfg;
}

// A device a Camera talks to, which the test can take away and bring back.
class Device {
 public:
  virtual ~Device() = default;
  virtual vgr::config::CameraConfig config() = 0;
  virtual void bringUp() = 0;
  virtual void takeAway() = 0;
  // The slowest a call may block on a vanished device (GVCP commands time out at ~2.5 s).
  virtual milliseconds worstBlock() const = 0;
  // What its frames are.
  virtual vgr::drivers::PixelType pixel() const { return vgr::drivers::PixelType::Mono8; }
};

// A 3D data set for the depth devices, once per process (removed at exit).
const vgr::test::DepthTestSet& depthSet() {
  struct Holder {
    vgr::test::DepthTestSet set;
    Holder() {
      const auto dir = fs::temp_directory_path() / ("vgr-depth-conf-" + std::to_string(::getpid()));
      fs::remove_all(dir);
      set = vgr::test::writeDepthTestSet(dir.string(), 3);
    }
    ~Holder() {
      std::error_code ec;
      fs::remove_all(set.dir, ec);
    }
  };
  static const Holder holder;
  return holder.set;
}

class DepthEmulatorDevice final : public Device {
 public:
  vgr::config::CameraConfig config() override {
    auto c = simCell().camera;
    c.pixelFormat = "Coord3D_C16";
    return c;
  }
  void bringUp() override {
    proc_ = vgr::test::startEmulator({"--depth", depthSet().dir}, "", milliseconds(15000));
    ASSERT_NE(proc_, nullptr) << "emulator did not start (port 3956 busy?)";
  }
  void takeAway() override {
    if (proc_) proc_->kill9();
    proc_.reset();
  }
  milliseconds worstBlock() const override { return milliseconds(3000); }
  vgr::drivers::PixelType pixel() const override { return vgr::drivers::PixelType::DepthMm; }

 private:
  std::unique_ptr<ChildProcess> proc_;
};

class DepthFolderDevice final : public Device {
 public:
  DepthFolderDevice() {
    // A copy of the set, so that taking it away does not disturb the other devices.
    dir_ = fs::temp_directory_path() / ("vgr-replay-depth-conf-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::copy(depthSet().dir, dir_, fs::copy_options::recursive);
  }
  ~DepthFolderDevice() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
    fs::remove_all(fs::path(dir_.string() + ".away"), ec);
  }
  vgr::config::CameraConfig config() override {
    auto c = simCell().camera;
    c.driver = "replay";
    c.pixelFormat = "Coord3D_C16";
    c.replayFolder = dir_.string();
    c.replayLoop = true;
    return c;
  }
  void bringUp() override {
    if (fs::exists(dir_.string() + ".away")) fs::rename(dir_.string() + ".away", dir_);
  }
  void takeAway() override { fs::rename(dir_, dir_.string() + ".away"); }
  milliseconds worstBlock() const override { return milliseconds(100); }
  vgr::drivers::PixelType pixel() const override { return vgr::drivers::PixelType::DepthMm; }

 private:
  fs::path dir_;
};

class EmulatorDevice final : public Device {
 public:
  vgr::config::CameraConfig config() override { return simCell().camera; }
  void bringUp() override {
    proc_ = vgr::test::startEmulator({"--seed", "3"});
    ASSERT_NE(proc_, nullptr) << "emulator did not start (port 3956 busy?)";
  }
  void takeAway() override {
    if (proc_) proc_->kill9();
    proc_.reset();
  }
  milliseconds worstBlock() const override { return milliseconds(3000); }

 private:
  std::unique_ptr<ChildProcess> proc_;
};

class FolderDevice final : public Device {
 public:
  FolderDevice() {
    dir_ = fs::temp_directory_path() / ("vgr-replay-conf-" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    auto cell = simCell();
    cell.sim.width = 320;
    cell.sim.height = 256;
    const auto r = vgr::sim::SceneRenderer::fromCellConfig(cell);
    for (int i = 1; i <= 3; ++i) {
      cv::Mat img;
      r.render(static_cast<std::uint64_t>(i), img);
      cv::imwrite((dir_ / ("frame" + std::to_string(i) + ".png")).string(), img);
    }
  }
  ~FolderDevice() override {
    std::error_code ec;
    fs::remove_all(dir_, ec);
    fs::remove_all(fs::path(dir_.string() + ".away"), ec);
  }
  vgr::config::CameraConfig config() override {
    auto c = simCell().camera;
    c.driver = "replay";
    c.replayFolder = dir_.string();
    c.replayLoop = true;
    return c;
  }
  void bringUp() override {
    if (fs::exists(dir_.string() + ".away")) fs::rename(dir_.string() + ".away", dir_);
  }
  void takeAway() override { fs::rename(dir_, dir_.string() + ".away"); }
  milliseconds worstBlock() const override { return milliseconds(100); }

 private:
  fs::path dir_;
};

std::unique_ptr<Device> makeDevice(const std::string& name) {
  if (name == "aravis") return std::make_unique<EmulatorDevice>();
  if (name == "aravis_depth") return std::make_unique<DepthEmulatorDevice>();
  if (name == "replay_depth") return std::make_unique<DepthFolderDevice>();
  return std::make_unique<FolderDevice>();
}

class CameraConformance : public ::testing::TestWithParam<std::string> {
 protected:
  void SetUp() override {
    device_ = makeDevice(GetParam());
    device_->bringUp();
  }
  void TearDown() override {
    camera_.reset();
    device_.reset();
  }
  vgr::drivers::Camera& camera(vgr::config::CameraConfig c) {
    auto made = vgr::drivers::makeCamera(c);
    EXPECT_TRUE(made.has_value());
    camera_ = std::move(*made);
    return *camera_;
  }
  vgr::drivers::Camera& camera() { return camera(device_->config()); }

  std::unique_ptr<Device> device_;
  std::unique_ptr<vgr::drivers::Camera> camera_;
};

TEST_P(CameraConformance, OpenStartStopCloseCycles) {
  auto& cam = camera();
  vgr::drivers::Frame frame;
  for (int round = 0; round < 3; ++round) {
    EXPECT_EQ(cam.state(), CameraState::Closed);
    ASSERT_TRUE(cam.open()) << cam.describe();
    EXPECT_EQ(cam.state(), CameraState::Open);
    for (int s = 0; s < 2; ++s) {
      ASSERT_TRUE(cam.start());
      EXPECT_EQ(cam.state(), CameraState::Streaming);
      auto r = cam.triggerAndWait(frame, milliseconds(2000));
      EXPECT_TRUE(r) << (r ? "" : r.error().message);
      cam.stop();
      EXPECT_EQ(cam.state(), CameraState::Open);
    }
    cam.close();
    EXPECT_EQ(cam.state(), CameraState::Closed);
  }
  cam.close();  // closing twice is harmless
  EXPECT_EQ(cam.state(), CameraState::Closed);
}

TEST_P(CameraConformance, EachTriggerGivesOneFreshFrame) {
  auto& cam = camera();
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.start());
  vgr::drivers::Frame frame;
  std::uint64_t lastId = 0, lastHost = 0;
  for (int i = 0; i < 5; ++i) {
    const auto before = std::chrono::system_clock::now();
    auto r = cam.triggerAndWait(frame, milliseconds(2000));
    ASSERT_TRUE(r) << r.error().message;
    EXPECT_EQ(cam.lastFrameStatus(), FrameStatus::Ok);
    EXPECT_GT(frame.width, 0);
    EXPECT_GT(frame.height, 0);
    EXPECT_EQ(frame.pixel, device_->pixel());
    EXPECT_EQ(frame.data.size(), static_cast<std::size_t>(frame.width) * frame.height * frame.bytesPerPixel());
    if (frame.depth()) {  // a depth frame carries its intrinsics
      EXPECT_GT(frame.intrinsics.fx, 0);
      EXPECT_GT(frame.intrinsics.fy, 0);
    }
    EXPECT_GT(frame.frameId, lastId);
    lastId = frame.frameId;
    // The host timestamp is this trigger's: not before it (minus clock granularity).
    const auto beforeNs = static_cast<std::uint64_t>(
        std::chrono::duration_cast<std::chrono::nanoseconds>(before.time_since_epoch()).count());
    EXPECT_GE(frame.hostTimestampNs + 2000000, beforeNs);
    EXPECT_GT(frame.hostTimestampNs, lastHost);
    lastHost = frame.hostTimestampNs;
  }
  EXPECT_EQ(cam.stats().completed, 5u);
}

TEST_P(CameraConformance, TriggerWithoutFrameTimesOutTyped) {
  // Hardware trigger with nobody firing the line: the frame never comes.
  auto c = device_->config();
  c.trigger = vgr::config::TriggerMode::Hardware;
  c.triggerLine = "Line0";  // the emulator's (Aravis fake camera's) only line
  auto& cam = camera(c);
  ASSERT_TRUE(cam.open()) << cam.describe();
  ASSERT_TRUE(cam.start());
  vgr::drivers::Frame frame;
  for (int i = 0; i < 2; ++i) {
    const auto t0 = Clock::now();
    auto r = cam.triggerAndWait(frame, milliseconds(300));
    const auto took = Clock::now() - t0;
    ASSERT_FALSE(r);
    EXPECT_EQ(r.error().code, vgr::Status::CameraError);
    EXPECT_EQ(cam.lastFrameStatus(), FrameStatus::Timeout) << r.error().message;
    EXPECT_GE(took, milliseconds(290));
    EXPECT_LT(took, milliseconds(800));
  }
  EXPECT_EQ(cam.stats().timeouts, 2u);
  EXPECT_EQ(cam.state(), CameraState::Streaming);  // a timeout is not a state change
}

TEST_P(CameraConformance, IllegalTransitionsAreRejected) {
  auto& cam = camera();
  vgr::drivers::Frame frame;
  EXPECT_FALSE(cam.start());  // Closed -> Streaming
  EXPECT_EQ(cam.state(), CameraState::Closed);
  auto t = cam.triggerAndWait(frame, milliseconds(100));
  ASSERT_FALSE(t);
  EXPECT_EQ(cam.lastFrameStatus(), FrameStatus::IllegalState);
  ASSERT_TRUE(cam.open());
  auto again = cam.open();  // Open -> Open
  ASSERT_FALSE(again);
  EXPECT_EQ(again.error().code, vgr::Status::Internal);
  EXPECT_EQ(cam.state(), CameraState::Open);
  EXPECT_FALSE(cam.triggerAndWait(frame, milliseconds(100)));  // Open, not streaming
  EXPECT_EQ(cam.lastFrameStatus(), FrameStatus::IllegalState);
  ASSERT_TRUE(cam.start());
  EXPECT_FALSE(cam.start());   // Streaming -> Streaming
  EXPECT_FALSE(cam.open());    // Streaming -> Open
  EXPECT_EQ(cam.state(), CameraState::Streaming);
  EXPECT_TRUE(cam.triggerAndWait(frame, milliseconds(2000)));  // still works
  cam.stop();
  cam.stop();  // stop when not streaming: no-op
  EXPECT_EQ(cam.state(), CameraState::Open);
  EXPECT_EQ(cam.stats().failed, 0u);  // illegal calls are not frame failures
}

TEST_P(CameraConformance, ReconnectsAfterTheDeviceDisappears) {
  auto& cam = camera();
  ASSERT_TRUE(cam.open());
  ASSERT_TRUE(cam.start());
  vgr::drivers::Frame frame;
  ASSERT_TRUE(cam.triggerAndWait(frame, milliseconds(2000)));

  device_->takeAway();
  const auto t0 = Clock::now();
  auto r = cam.triggerAndWait(frame, milliseconds(500));
  EXPECT_LT(Clock::now() - t0, device_->worstBlock());
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, vgr::Status::CameraError);
  const FrameStatus st = cam.lastFrameStatus();
  EXPECT_TRUE(st == FrameStatus::Disconnected || st == FrameStatus::Timeout) << vgr::drivers::frameStatusName(st);
  const auto c0 = Clock::now();
  cam.close();
  EXPECT_LT(Clock::now() - c0, milliseconds(500)) << "close() must not wait on a vanished device";
  EXPECT_EQ(cam.state(), CameraState::Closed);
  EXPECT_FALSE(cam.open()) << "opened a device that is not there";
  EXPECT_EQ(cam.state(), CameraState::Closed);

  device_->bringUp();
  ASSERT_TRUE(cam.open()) << cam.describe();
  ASSERT_TRUE(cam.start());
  auto ok = cam.triggerAndWait(frame, milliseconds(2000));
  EXPECT_TRUE(ok) << (ok ? "" : ok.error().message);
}

INSTANTIATE_TEST_SUITE_P(camera, CameraConformance, ::testing::Values("aravis", "replay", "aravis_depth", "replay_depth"),
                         [](const auto& p) { return p.param; });

}  // namespace
