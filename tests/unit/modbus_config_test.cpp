// The modbus: section of the cell config (config/cell_config.hpp): new keys, defaults and
// the "FILE:LINE: key 'a.b': ..." error form.
#include "config/cell_config.hpp"

#include <gtest/gtest.h>

#include <string>

namespace vgr::config {
namespace {

std::string withModbus(const std::string& modbusBlock) {
  std::string y = embeddedSimCellYaml();
  const auto start = y.find("\nmodbus:\n");
  const auto end = y.find("\nrobots:", start);
  return y.substr(0, start + 1) + modbusBlock + y.substr(end);
}

TEST(modbus_config, ExampleHasDefaults) {
  const auto c = parseCellConfig(embeddedSimCellYaml(), "sim-cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_EQ(c->modbus.maxClients, 8);
  EXPECT_FALSE(c->modbus.requireTriggerEnable);
  EXPECT_FALSE(c->modbus.client.enabled);
  EXPECT_EQ(c->modbus.client.statusAddress, 100);
}

TEST(modbus_config, ClientSection) {
  const auto c = parseCellConfig(withModbus("modbus:\n  require_trigger_enable: true\n  max_clients: 3\n  client:\n"
                                            "    enabled: true\n    host: 10.0.0.5\n    port: 502\n    unit_id: 7\n"
                                            "    trigger: coil\n    trigger_address: 12\n    status_address: 200\n"
                                            "    poll_ms: 2\n    debounce_ms: 0\n    job: 1\n"),
                                 "cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_TRUE(c->modbus.requireTriggerEnable);
  EXPECT_EQ(c->modbus.maxClients, 3);
  const auto& m = c->modbus.client;
  EXPECT_TRUE(m.enabled);
  EXPECT_EQ(m.host, "10.0.0.5");
  EXPECT_EQ(m.port, 502);
  EXPECT_EQ(m.unitId, 7);
  EXPECT_EQ(m.trigger, TriggerInputKind::Coil);
  EXPECT_EQ(m.triggerAddress, 12);
  EXPECT_EQ(m.statusAddress, 200);
  EXPECT_EQ(m.pollMs, 2);
  EXPECT_EQ(m.debounceMs, 0);
  EXPECT_EQ(m.job, 1);
}

TEST(modbus_config, ErrorsNameFileLineAndKey) {
  auto c = parseCellConfig(withModbus("modbus:\n  client:\n    poll_ms: 0\n"), "cell.yaml");
  ASSERT_FALSE(c.has_value());
  EXPECT_NE(c.error().message.find("key 'modbus.client.poll_ms': out of range"), std::string::npos) << c.error().message;
  EXPECT_EQ(c.error().message.rfind("cell.yaml:", 0), 0u) << c.error().message;

  c = parseCellConfig(withModbus("modbus:\n  client:\n    trigger: laser\n"), "cell.yaml");
  ASSERT_FALSE(c.has_value());
  EXPECT_NE(c.error().message.find("key 'modbus.client.trigger'"), std::string::npos) << c.error().message;

  c = parseCellConfig(withModbus("modbus:\n  max_clients: 65\n"), "cell.yaml");
  ASSERT_FALSE(c.has_value());
  EXPECT_NE(c.error().message.find("key 'modbus.max_clients'"), std::string::npos) << c.error().message;

  c = parseCellConfig(withModbus("modbus:\n  client:\n    debounce_m: 5\n"), "cell.yaml");
  ASSERT_FALSE(c.has_value());
  EXPECT_NE(c.error().message.find("key 'modbus.client.debounce_m': unknown key (did you mean 'debounce_ms'?)"),
            std::string::npos)
      << c.error().message;
}

}  // namespace
}  // namespace vgr::config
