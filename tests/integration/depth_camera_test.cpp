// The depth camera through the real GigE Vision stack (issue 14): the Aravis driver with
// pixel_format Coord3D_C16 against vgr-sim-camera --depth (Aravis' fake GigE camera with the
// Scan3dControl features, a separate process, GVCP/GVSP over loopback) serving a 3D data set.
//  - Every frame is the data set's image in mm, exactly: raw x Scan3dCoordinateScale read from
//    the camera, 0 where the image has no data; the intrinsics are Scan3dFocalLength and
//    Scan3dPrincipalPointU/V; the emulator's truth names the image of each frame id.
//  - The unit is read, not assumed: a camera reporting Inch (and a scale in inches) gives the
//    same millimetres; one reporting Pixel is refused with a line naming Scan3dDistanceUnit;
//    a 2D camera asked for Coord3D_C16 is refused naming PixelFormat.
//  - Lost frames (GVSP packet loss) are typed, counted and re-triggered by the CameraWorker
//    exactly as for the 2D camera.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <set>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "drivers/camera.hpp"
#include "drivers/camera_worker.hpp"
#include "tests/support/depth_dataset.hpp"
#include "tests/support/processes.hpp"

namespace {

namespace fs = std::filesystem;
using std::chrono::milliseconds;
using vgr::drivers::FrameStatus;

class DepthCamera : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           ("vgr-depth-camera-" + std::to_string(::getpid()) + "-" + ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    set_ = vgr::test::writeDepthTestSet((dir_ / "set").string(), 3);
  }
  void TearDown() override {
    emulator_.reset();
    std::error_code ec;
    if (!HasFailure()) fs::remove_all(dir_, ec);
  }
  void startEmulator(std::vector<std::string> extra = {}) {
    std::vector<std::string> args = {"--depth", set_.dir, "--truth", (dir_ / "truth.jsonl").string()};
    args.insert(args.end(), extra.begin(), extra.end());
    // 15 s: a first start of the emulator on a loaded machine loads its libraries from disk.
    emulator_ = vgr::test::startEmulator(args, (dir_ / "camera.log").string(), milliseconds(15000));
    ASSERT_NE(emulator_, nullptr);
  }
  vgr::config::CameraConfig config() const {
    auto cell = *vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
    auto c = cell.camera;
    c.pixelFormat = "Coord3D_C16";
    return c;
  }
  // The emulator's truth line of a frame id (the image it served).
  std::string imageOfFrame(std::uint64_t frameId) const {
    std::ifstream in(dir_ / "truth.jsonl");
    for (std::string line; std::getline(in, line);) {
      const auto j = nlohmann::json::parse(line, nullptr, false);
      if (!j.is_discarded() && j.value("frame_id", 0ull) == frameId) return j.value("image", std::string());
    }
    return {};
  }
  // Max |frame - image * scale| over all pixels (mm), and the count of pixels without data.
  void compare(const vgr::drivers::Frame& frame, const std::string& image, double& maxErr, int& holes) const {
    const cv::Mat raw = cv::imread((fs::path(set_.dir) / image).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(raw.type(), CV_16UC1);
    ASSERT_EQ(frame.width, raw.cols);
    ASSERT_EQ(frame.height, raw.rows);
    const cv::Mat z(frame.height, frame.width, CV_32FC1, const_cast<std::uint8_t*>(frame.data.data()));
    maxErr = 0;
    holes = 0;
    for (int v = 0; v < raw.rows; ++v)
      for (int u = 0; u < raw.cols; ++u) {
        const double expected = raw.at<std::uint16_t>(v, u) * set_.depthScaleMm;
        maxErr = std::max(maxErr, std::abs(z.at<float>(v, u) - expected));
        if (z.at<float>(v, u) == 0.0f) ++holes;
      }
  }

  fs::path dir_;
  vgr::test::DepthTestSet set_;
  std::unique_ptr<vgr::test::ChildProcess> emulator_;
};

TEST_F(DepthCamera, FramesAreTheDataSetInMillimetresWithTheCamerasIntrinsics) {
  ASSERT_NO_FATAL_FAILURE(startEmulator());
  auto made = vgr::drivers::makeCamera(config());
  ASSERT_TRUE(made);
  auto& cam = **made;
  ASSERT_TRUE(cam.open()) << cam.describe();
  ASSERT_TRUE(cam.start());
  vgr::drivers::Frame frame;
  std::set<std::string> seen;
  for (int i = 0; i < 4; ++i) {
    auto r = cam.triggerAndWait(frame, milliseconds(2000));
    ASSERT_TRUE(r) << r.error().message;
    ASSERT_TRUE(frame.depth());
    EXPECT_EQ(frame.intrinsics.fx, 570.0);  // Scan3dFocalLength (camera.yaml's fx = fy)
    EXPECT_EQ(frame.intrinsics.fy, 570.0);
    EXPECT_EQ(frame.intrinsics.cx, 319.5);  // Scan3dPrincipalPointU/V
    EXPECT_EQ(frame.intrinsics.cy, 239.5);
    const std::string image = imageOfFrame(frame.frameId);
    ASSERT_FALSE(image.empty()) << "no truth for frame " << frame.frameId;
    seen.insert(image);
    double maxErr = 0;
    int holes = 0;
    ASSERT_NO_FATAL_FAILURE(compare(frame, image, maxErr, holes));
    EXPECT_LT(maxErr, 1e-3) << image;  // float32 of raw x 0.05 mm
    EXPECT_GT(holes, 0) << "the background has no data: Scan3dInvalidDataValue 0";
  }
  EXPECT_EQ(seen.size(), 3u);  // the emulator walked the set
  EXPECT_EQ(cam.stats().completed, 4u);
}

TEST_F(DepthCamera, TheUnitIsReadFromTheCameraAndAnUnusableOneIsRefused) {
  ASSERT_NO_FATAL_FAILURE(startEmulator({"--depth-unit", "Inch"}));
  {
    auto made = vgr::drivers::makeCamera(config());
    ASSERT_TRUE(made);
    auto& cam = **made;
    ASSERT_TRUE(cam.open()) << cam.describe();
    ASSERT_TRUE(cam.start());
    vgr::drivers::Frame frame;
    ASSERT_TRUE(cam.triggerAndWait(frame, milliseconds(2000)));
    double maxErr = 0;
    int holes = 0;
    ASSERT_NO_FATAL_FAILURE(compare(frame, imageOfFrame(frame.frameId), maxErr, holes));
    EXPECT_LT(maxErr, 1e-3) << "Inch x 25.4 must give the same millimetres";
  }
  emulator_.reset();
  ASSERT_NO_FATAL_FAILURE(startEmulator({"--depth-unit", "Pixel"}));
  auto made = vgr::drivers::makeCamera(config());
  ASSERT_TRUE(made);
  auto r = (*made)->open();
  ASSERT_FALSE(r);
  EXPECT_EQ(r.error().code, vgr::Status::CameraError);
  EXPECT_NE(r.error().message.find("Scan3dDistanceUnit is 'Pixel'"), std::string::npos) << r.error().message;
  EXPECT_EQ((*made)->state(), vgr::drivers::CameraState::Closed);
}

TEST_F(DepthCamera, A2dCameraIsRefusedNamingThePixelFormat) {
  emulator_ = vgr::test::startEmulator({"--seed", "3"}, (dir_ / "camera.log").string(), milliseconds(15000));
  ASSERT_NE(emulator_, nullptr);
  auto made = vgr::drivers::makeCamera(config());
  ASSERT_TRUE(made);
  auto r = (*made)->open();
  ASSERT_FALSE(r);
  EXPECT_NE(r.error().message.find("PixelFormat has no 'Coord3D_C16'"), std::string::npos) << r.error().message;
}

TEST_F(DepthCamera, LostFramesAreTypedCountedAndRetriggered) {
  // 1 % of GVSP packets lost: a 640 x 480 depth frame is 38 packets of 16 kB, so about a
  // third of the frames is lost; two re-triggers within the deadline recover most of them.
  ASSERT_NO_FATAL_FAILURE(startEmulator({"--loss", "0.01"}));
  auto c = config();
  c.retries = 2;
  c.timeoutMs = 400;
  auto made = vgr::drivers::makeCamera(c);
  ASSERT_TRUE(made);
  vgr::drivers::CameraWorker worker(c, std::move(*made));
  worker.start();
  ASSERT_TRUE(worker.waitStreaming(milliseconds(5000)));
  vgr::drivers::Frame frame;
  int ok = 0;
  for (int i = 0; i < 20; ++i) {
    FrameStatus st = FrameStatus::Failed;
    auto r = worker.grab(frame, std::chrono::steady_clock::now() + milliseconds(1400), &st);
    if (r) {
      ++ok;
      EXPECT_TRUE(frame.depth());
      EXPECT_EQ(st, FrameStatus::Ok);
    } else {
      EXPECT_TRUE(st == FrameStatus::Incomplete || st == FrameStatus::Timeout) << vgr::drivers::frameStatusName(st);
    }
  }
  const auto k = worker.counters();
  worker.stop();
  EXPECT_EQ(k.completed + k.failed + k.abandoned, 20u);
  EXPECT_EQ(static_cast<int>(k.completed), ok);
  EXPECT_GT(k.retries, 0u) << "no frame was lost: the loss setting did not apply";
  EXPECT_GT(k.recovered, 0u);
  EXPECT_GT(k.missingPackets, 0u);
  EXPECT_GE(ok, 15);
}

}  // namespace
