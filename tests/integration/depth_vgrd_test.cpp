// vgrd with a depth camera it cannot use, and with a depth camera its 2D job cannot use
// (issue 14, bad input): typed errors, one log line naming why, vgrd serving on.
//  - The emulator reports Scan3dDistanceUnit 'Pixel': the driver refuses the camera at every
//    (re)connect with a line naming the feature; a robot's TRIG is answered -4 CAMERA_ERROR
//    within its deadline, again and again.
//  - A usable depth camera under the example's 2D moments job: every cycle ends -2
//    BAD_ARGUMENT ("a 2D method cannot locate in the depth frames"), journalled.
#include <chrono>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>

#include "tests/support/depth_dataset.hpp"
#include "tests/support/raw_tcp_client.hpp"
#include "tests/support/sim_cell.hpp"

namespace {

using namespace std::chrono_literals;

// "(status,cycle,...)" -> status.
int urStatus(const std::string& reply) {
  if (reply.size() < 3 || reply.front() != '(') return -99;
  return std::stoi(reply.substr(1, reply.find(',') - 1));
}

class depth_vgrd : public vgr::test::SimCell {
 protected:
  void startDepthCell(const std::string& unit, bool waitReady) {
    ASSERT_NO_FATAL_FAILURE(prepareCell([](std::string yaml) {
      const auto at = yaml.find("pixel_format: Mono8");
      EXPECT_NE(at, std::string::npos);
      yaml.replace(at, 19, "pixel_format: Coord3D_C16");
      return yaml;
    }));
    set_ = vgr::test::writeDepthTestSet((dir_ / "set").string(), 2);
    camera_ = vgr::test::startEmulator({"--depth", set_.dir, "--depth-unit", unit}, (dir_ / "camera.log").string(),
                                       std::chrono::milliseconds(15000));
    ASSERT_NE(camera_, nullptr);
    if (waitReady) {
      ASSERT_NO_FATAL_FAILURE(startVgrd());
      return;
    }
    // The camera never streams: vgrd starts (robots and Modbus are served) but never READY.
    notify_ = std::make_unique<vgr::test::NotifySocket>((dir_ / "notify.sock").string());
    auto p = vgr::test::spawnWithNotify({bin("vgrd"), "--config", configPath_, "--journal", journalPath()},
                                        (dir_ / "vgrd.log").string(), *notify_);
    ASSERT_TRUE(p.has_value());
    vgrd_ = std::make_unique<vgr::test::ChildProcess>(std::move(*p));
  }
  vgr::test::DepthTestSet set_;
};

TEST_F(depth_vgrd, a_camera_in_an_unknown_unit_is_refused_and_vgrd_answers_camera_error) {
  ASSERT_NO_FATAL_FAILURE(startDepthCell("Pixel", false));
  // The robot port comes up while the camera is being refused.
  std::unique_ptr<vgr::test::RawTcpClient> ur;
  for (int i = 0; i < 100 && !ur; ++i) {
    vgr::test::RawTcpClient::Options o;
    o.throwOnFailure = false;
    auto c = std::make_unique<vgr::test::RawTcpClient>(kUrPort, o);
    if (c->connected()) ur = std::move(c);
    else std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(ur) << log("vgrd.log");
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(ur->send("TRIG,1\n"));
    const auto reply = ur->readUntil(')', 3000ms);
    ASSERT_TRUE(reply) << log("vgrd.log");
    EXPECT_EQ(urStatus(*reply), -4) << *reply;
  }
  EXPECT_TRUE(vgrd_->running());
  // The camera worker logs why it refuses the camera when its connect attempt ends, which
  // may be after the two cycles above were answered (they do not wait for the camera): wait
  // for the line (up to 10 s) rather than read the log once (failed so under load).
  std::string l = log("vgrd.log");
  for (int i = 0; i < 100 && l.find("Scan3dDistanceUnit is 'Pixel'") == std::string::npos; ++i) {
    std::this_thread::sleep_for(100ms);
    l = log("vgrd.log");
  }
  EXPECT_NE(l.find("Scan3dDistanceUnit is 'Pixel'"), std::string::npos) << l;
}

TEST_F(depth_vgrd, a_2d_job_on_a_depth_camera_is_a_typed_error_per_cycle) {
  ASSERT_NO_FATAL_FAILURE(startDepthCell("Millimeter", true));
  vgr::test::RawTcpClient ur(kUrPort);
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(ur.send("TRIG,1\n"));
    const auto reply = ur.readUntil(')', 3000ms);
    ASSERT_TRUE(reply);
    EXPECT_EQ(urStatus(*reply), -2) << *reply;
  }
  const auto j = journal();
  ASSERT_GE(j.size(), 2u);
  EXPECT_EQ(j.back()["status"], -2);
  EXPECT_GT(j.back()["frame_id"].get<std::uint64_t>(), 0u) << "the depth frame arrived";
  EXPECT_NE(log("vgrd.log").find("a 2D method cannot locate in the depth frames"), std::string::npos);
  EXPECT_TRUE(vgrd_->running());
}

}  // namespace
