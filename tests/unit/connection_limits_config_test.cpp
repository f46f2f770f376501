// Connection-slot keys of the cell config (config/cell_config.hpp): modbus.idle_timeout_ms,
// modbus.allowed_clients and robots[].idle_timeout_ms, their defaults and range errors.
#include "config/cell_config.hpp"

#include <gtest/gtest.h>

#include <string>
#include <vector>

namespace vgr::config {
namespace {

std::string withModbus(const std::string& modbusBlock) {
  std::string y = embeddedSimCellYaml();
  const auto start = y.find("\nmodbus:\n");
  const auto end = y.find("\nrobots:", start);
  return y.substr(0, start + 1) + modbusBlock + y.substr(end);
}

TEST(connection_limits_config, Defaults) {
  const auto c = parseCellConfig(embeddedSimCellYaml(), "sim-cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_EQ(c->modbus.idleTimeoutMs, 60000);
  EXPECT_TRUE(c->modbus.allowedClients.empty());
  ASSERT_FALSE(c->robots.empty());
  for (const auto& r : c->robots) EXPECT_EQ(r.idleTimeoutMs, 0) << r.name;
}

TEST(connection_limits_config, ModbusKeys) {
  const auto c = parseCellConfig(
      withModbus("modbus:\n  idle_timeout_ms: 0\n  allowed_clients: [192.168.1.10, 10.0.0.5]\n"), "cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_EQ(c->modbus.idleTimeoutMs, 0);
  EXPECT_EQ(c->modbus.allowedClients, (std::vector<std::string>{"192.168.1.10", "10.0.0.5"}));
}

TEST(connection_limits_config, ModbusErrors) {
  const auto neg = parseCellConfig(withModbus("modbus:\n  idle_timeout_ms: -1\n"), "cell.yaml");
  ASSERT_FALSE(neg.has_value());
  EXPECT_NE(neg.error().message.find("modbus.idle_timeout_ms"), std::string::npos) << neg.error().message;
  const auto host = parseCellConfig(withModbus("modbus:\n  allowed_clients: [plc.local]\n"), "cell.yaml");
  ASSERT_FALSE(host.has_value());
  EXPECT_NE(host.error().message.find("plc.local"), std::string::npos) << host.error().message;
  const auto v6 = parseCellConfig(withModbus("modbus:\n  allowed_clients: ['fe80::1']\n"), "cell.yaml");
  EXPECT_FALSE(v6.has_value()) << "the Modbus server listens on IPv4 only";
}

TEST(connection_limits_config, RobotIdleTimeout) {
  std::string y = embeddedSimCellYaml();
  const auto at = y.find("    reply_deadline_ms: 1500         # below URScript");
  ASSERT_NE(at, std::string::npos);
  y.insert(at, "    idle_timeout_ms: 600000\n");
  const auto c = parseCellConfig(y, "cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_EQ(c->robots.front().idleTimeoutMs, 600000);
  std::string bad = embeddedSimCellYaml();
  bad.insert(bad.find("    reply_deadline_ms: 1500         # below URScript"), "    idle_timeout_ms: 86400001\n");
  EXPECT_FALSE(parseCellConfig(bad, "cell.yaml").has_value());
}

}  // namespace
}  // namespace vgr::config
