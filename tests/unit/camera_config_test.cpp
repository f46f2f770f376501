// The camera: section of the cell config: new keys parse, bad values name FILE:LINE and key.
#include <string>

#include <gtest/gtest.h>

#include "config/cell_config.hpp"

namespace {

using vgr::config::parseCellConfig;

std::string cell(const std::string& camera) {
  return "cell: {name: t}\ncamera:\n" + camera + "model: {fx: 1000}\njobs:\n  - id: 1\n";
}

TEST(camera_config, DefaultsKeepTheSimCellBehaviour) {
  auto c = parseCellConfig(vgr::config::embeddedSimCellYaml(), "sim-cell.yaml");
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->camera.pixelFormat, "Mono8");
  EXPECT_EQ(c->camera.trigger, vgr::config::TriggerMode::Software);
  EXPECT_EQ(c->camera.retries, 1);
  EXPECT_FALSE(c->camera.packetResend);
  EXPECT_EQ(c->camera.packetSize, 16384);
}

TEST(camera_config, AllKeysParse) {
  auto c = parseCellConfig(cell("  serial: S1\n  user_name: infeed\n  pixel_format: BayerRG8\n  gain: 2.5\n"
                                "  roi: {x: 8, y: 4, width: 640, height: 480}\n  packet_delay_ns: 1000\n"
                                "  socket_buffer_bytes: 8388608\n  packet_resend: true\n  buffers: 8\n  retries: 2\n"
                                "  trigger: {mode: hardware, line: Line1, activation: FallingEdge, delay_us: 150}\n"),
                           "c.yaml");
  ASSERT_TRUE(c) << c.error().message;
  const auto& k = c->camera;
  EXPECT_EQ(k.serial, "S1");
  EXPECT_EQ(k.userName, "infeed");
  EXPECT_EQ(k.pixelFormat, "BayerRG8");
  EXPECT_DOUBLE_EQ(k.gain, 2.5);
  EXPECT_EQ(k.roiX, 8);
  EXPECT_EQ(k.roiHeight, 480);
  EXPECT_EQ(k.packetDelayNs, 1000);
  EXPECT_EQ(k.socketBufferBytes, 8388608);
  EXPECT_EQ(k.bufferCount, 8);
  EXPECT_EQ(k.retries, 2);
  EXPECT_EQ(k.trigger, vgr::config::TriggerMode::Hardware);
  EXPECT_EQ(k.triggerLine, "Line1");
  EXPECT_EQ(k.triggerActivation, "FallingEdge");
  EXPECT_DOUBLE_EQ(k.triggerDelayUs, 150);
}

TEST(camera_config, ReplayNeedsAFolder) {
  auto c = parseCellConfig(cell("  driver: replay\n"), "c.yaml");
  ASSERT_FALSE(c);
  EXPECT_NE(c.error().message.find("key 'camera.replay.folder'"), std::string::npos) << c.error().message;
  auto ok = parseCellConfig(cell("  driver: replay\n  replay: {folder: /tmp/x, loop: false}\n"), "c.yaml");
  ASSERT_TRUE(ok) << ok.error().message;
  EXPECT_FALSE(ok->camera.replayLoop);
}

TEST(camera_config, BadValuesNameLineAndKey) {
  struct Case {
    std::string yaml, key;
  };
  const Case cases[] = {
      {"  address: 127.0.0.1\n  pixel_format: RGB8\n", "c.yaml:4: key 'camera.pixel_format'"},
      {"  address: 127.0.0.1\n  trigger: {mode: laser}\n", "c.yaml:4: key 'camera.trigger.mode'"},
      {"  address: 127.0.0.1\n  trigger: {mode: hardware, edge: up}\n", "c.yaml:4: key 'camera.trigger.edge': unknown key"},
      {"  address: 127.0.0.1\n  retries: 11\n", "c.yaml:4: key 'camera.retries'"},
      {"  address: 127.0.0.1\n  buffers: 1\n", "c.yaml:4: key 'camera.buffers'"},
      {"  address: 127.0.0.1\n  roi: {x: -1}\n", "c.yaml:4: key 'camera.roi.x'"},
      {"  address: 127.0.0.1\n  socket_buffer_bytes: 100\n", "c.yaml:4: key 'camera.socket_buffer_bytes'"},
      {"  name: c\n", "key 'camera.address': an aravis camera needs an address, a serial or a user_name"},
  };
  for (const auto& k : cases) {
    auto c = parseCellConfig(cell(k.yaml), "c.yaml");
    ASSERT_FALSE(c) << k.yaml;
    EXPECT_NE(c.error().message.find(k.key), std::string::npos) << c.error().message;
  }
}

}  // namespace
