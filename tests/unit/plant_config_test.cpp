// The web: and mqtt: sections of the cell config (config/cell_config.hpp): off when absent,
// on when present, defaults, and the "FILE:LINE: key 'a.b': ..." error form.
#include "config/cell_config.hpp"

#include <gtest/gtest.h>

#include <string>

namespace vgr::config {
namespace {

Result<CellConfig> withTail(const std::string& tail) {
  return parseCellConfig(embeddedSimCellYaml() + "\n" + tail, "cell.yaml");
}

TEST(plant_config, AbsentSectionsAreOff) {
  const auto c = parseCellConfig(embeddedSimCellYaml(), "sim-cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_FALSE(c->web.enabled);
  EXPECT_FALSE(c->mqtt.enabled);
}

TEST(plant_config, WebSection) {
  const auto c = withTail("web:\n  bind: 0.0.0.0\n  port: 9100\n");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_TRUE(c->web.enabled);
  EXPECT_EQ(c->web.bind, "0.0.0.0");
  EXPECT_EQ(c->web.port, 9100);
  const auto off = withTail("web:\n  enabled: false\n");
  ASSERT_TRUE(off.has_value());
  EXPECT_FALSE(off->web.enabled);
}

TEST(plant_config, WebErrorsNameTheKey) {
  const auto port = withTail("web:\n  port: 0\n");
  ASSERT_FALSE(port.has_value());
  EXPECT_NE(port.error().message.find("key 'web.port'"), std::string::npos) << port.error().message;
  const auto bind = withTail("web:\n  bind: localhost\n");
  ASSERT_FALSE(bind.has_value());
  EXPECT_NE(bind.error().message.find("key 'web.bind'"), std::string::npos) << bind.error().message;
  const auto typo = withTail("web:\n  prot: 8080\n");
  ASSERT_FALSE(typo.has_value());
  EXPECT_NE(typo.error().message.find("did you mean 'port'"), std::string::npos) << typo.error().message;
}

TEST(plant_config, MqttDefaultsAndKeys) {
  const auto d = withTail("mqtt:\n  host: broker.plant\n");
  ASSERT_TRUE(d.has_value()) << d.error().message;
  EXPECT_TRUE(d->mqtt.enabled);
  EXPECT_EQ(d->mqtt.host, "broker.plant");
  EXPECT_EQ(d->mqtt.port, 1883);
  EXPECT_EQ(d->mqtt.prefix, "vgr");
  EXPECT_EQ(d->mqtt.queueCapacity, 1000);
  EXPECT_TRUE(d->mqtt.tlsCaFile.empty());

  const auto c = withTail("mqtt:\n  host: 10.1.2.3\n  port: 8883\n  prefix: plant/hall2\n  client_id: cell7\n"
                          "  username: vgr\n  password: secret\n  tls:\n    ca_file: /etc/vgr/ca.pem\n"
                          "    cert_file: /etc/vgr/c.pem\n    key_file: /etc/vgr/c.key\n  keepalive_s: 10\n"
                          "  queue: 50\n  reconnect_min_s: 2\n  reconnect_max_s: 60\n");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  const auto& m = c->mqtt;
  EXPECT_EQ(m.port, 8883);
  EXPECT_EQ(m.prefix, "plant/hall2");
  EXPECT_EQ(m.clientId, "cell7");
  EXPECT_EQ(m.username, "vgr");
  EXPECT_EQ(m.password, "secret");
  EXPECT_EQ(m.tlsCaFile, "/etc/vgr/ca.pem");
  EXPECT_EQ(m.tlsKeyFile, "/etc/vgr/c.key");
  EXPECT_EQ(m.keepaliveS, 10);
  EXPECT_EQ(m.queueCapacity, 50);
  EXPECT_EQ(m.reconnectMaxS, 60);
}

TEST(plant_config, MqttErrorsNameTheKey) {
  const std::pair<const char*, const char*> cases[] = {
      {"mqtt:\n  prefix: vgr/#\n", "key 'mqtt.prefix'"},
      {"mqtt:\n  prefix: vgr/\n", "key 'mqtt.prefix'"},
      {"mqtt:\n  password: x\n", "key 'mqtt.password'"},
      {"mqtt:\n  queue: 0\n", "key 'mqtt.queue'"},
      {"mqtt:\n  reconnect_min_s: 10\n  reconnect_max_s: 5\n", "key 'mqtt.reconnect_max_s'"},
      {"mqtt:\n  tls:\n    cert_file: c.pem\n", "key 'mqtt.tls.key_file'"},
      {"mqtt:\n  tls:\n    cert_file: c.pem\n    key_file: c.key\n", "key 'mqtt.tls.ca_file'"},
  };
  for (const auto& [yaml, key] : cases) {
    const auto c = withTail(yaml);
    ASSERT_FALSE(c.has_value()) << yaml;
    EXPECT_NE(c.error().message.find(key), std::string::npos) << yaml << " -> " << c.error().message;
  }
}

}  // namespace
}  // namespace vgr::config
