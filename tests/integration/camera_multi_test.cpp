// Two cameras on one emulator (different serials and interface addresses): `vgr cameras`
// lists both, and the Aravis driver opens each by serial and gets that camera's own
// scenes byte for byte (camera i renders seed + i).
//
// Needs 127.0.0.2 on the loopback interface (Aravis binds a fake camera to an interface
// address). The test adds it when it runs as root (CI does); otherwise it fails and says
// the one command to run: `ip addr add 127.0.0.2/8 dev lo`.
#include <cstdio>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "config/cell_config.hpp"
#include "drivers/camera.hpp"
#include "sim/scene.hpp"
#include "tests/support/command.hpp"
#include "tests/support/processes.hpp"

namespace {

using std::chrono::milliseconds;

std::string run(const std::string& cmd) { return vgr::test::runCommand(cmd + " 2>&1").out; }

bool hasSecondLoopbackAddress() { return run("ip -4 addr show dev lo").find("127.0.0.2/") != std::string::npos; }

TEST(camera_multi, TwoCamerasBySerialEachServeTheirOwnScenes) {
  if (!hasSecondLoopbackAddress()) run("ip addr add 127.0.0.2/8 dev lo");
  ASSERT_TRUE(hasSecondLoopbackAddress()) << "run `ip addr add 127.0.0.2/8 dev lo` (as root) once on this machine";

  constexpr std::uint64_t kSeed = 21;
  auto emulator = vgr::test::startEmulator({"--seed", std::to_string(kSeed), "--camera", "VGR-A@127.0.0.1", "--camera", "VGR-B@127.0.0.2"});
  ASSERT_NE(emulator, nullptr);

  const auto listed = nlohmann::json::parse(run(std::string(VGR_BIN_DIR) + "/vgr cameras --json"), nullptr, false);
  ASSERT_TRUE(listed.is_array()) << listed.dump();
  std::map<std::string, std::string> addressOf;
  for (const auto& c : listed) addressOf[c.value("serial", "")] = c.value("address", "");
  EXPECT_EQ(addressOf["VGR-A"], "127.0.0.1");
  EXPECT_EQ(addressOf["VGR-B"], "127.0.0.2");

  auto cell = vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
  ASSERT_TRUE(cell.has_value());
  for (const auto& [serial, seed] : {std::pair{"VGR-A", kSeed}, {"VGR-B", kSeed + 1}}) {
    auto cfg = *cell;
    cfg.camera.address.clear();
    cfg.camera.serial = serial;
    cfg.sim.seed = seed;
    const auto renderer = vgr::sim::SceneRenderer::fromCellConfig(cfg);
    auto cam = vgr::drivers::makeCamera(cfg.camera);
    ASSERT_TRUE(cam.has_value());
    auto& camera = **cam;
    ASSERT_TRUE(camera.open()) << camera.describe();
    ASSERT_TRUE(camera.start()) << camera.describe();
    vgr::drivers::Frame frame;
    for (int i = 0; i < 3; ++i) {
      auto r = camera.triggerAndWait(frame, milliseconds(2000));
      ASSERT_TRUE(r) << serial << ": " << r.error().message;
      cv::Mat expected;
      renderer.render(frame.frameId, expected);
      const cv::Mat got(frame.height, frame.width, CV_8UC1, frame.data.data());
      EXPECT_EQ(cv::norm(got, expected, cv::NORM_INF), 0.0) << serial << " frame " << frame.frameId;
    }
    camera.stop();
    camera.close();
  }
}

}  // namespace
