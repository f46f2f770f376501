// Connection-slot keys of the cell config (config/cell_config.hpp): modbus.idle_timeout_ms,
// modbus.allowed_clients and robots[].idle_timeout_ms, their defaults and range errors.
#include "config/cell_config.hpp"

#include <gtest/gtest.h>

#include <algorithm>
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

// Issue 19, items 2 and 6: per-address limits, stale replacement, control clients.
TEST(connection_limits_config, PerAddressAndControlDefaults) {
  const auto c = parseCellConfig(embeddedSimCellYaml(), "sim-cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_EQ(c->modbus.maxClientsPerAddress, kDefaultMaxClientsPerAddress);
  for (const auto& r : c->robots) {
    EXPECT_EQ(r.maxClientsPerAddress, std::min(kDefaultMaxClientsPerAddress, r.maxClients)) << r.name;
    EXPECT_EQ(r.staleAfterMs, 10000) << r.name;
  }
}

TEST(connection_limits_config, PerAddressAndControlKeys) {
  const auto c = parseCellConfig(
      withModbus("modbus:\n  max_clients: 2\n  control_clients: [10.0.0.5]\n"), "cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_EQ(c->modbus.maxClientsPerAddress, 2) << "the default is capped at max_clients";
  EXPECT_EQ(c->modbus.controlClients, (std::vector<std::string>{"10.0.0.5"}));
  const auto over = parseCellConfig(withModbus("modbus:\n  max_clients: 2\n  max_clients_per_address: 3\n"), "cell.yaml");
  ASSERT_FALSE(over.has_value());
  EXPECT_NE(over.error().message.find("modbus.max_clients_per_address"), std::string::npos) << over.error().message;
  const auto badControl = parseCellConfig(withModbus("modbus:\n  control_clients: [plc.local]\n"), "cell.yaml");
  ASSERT_FALSE(badControl.has_value());
  EXPECT_NE(badControl.error().message.find("control_clients[0]"), std::string::npos) << badControl.error().message;

  std::string y = embeddedSimCellYaml();
  const auto at = y.find("    reply_deadline_ms: 1500         # below URScript");
  y.insert(at, "    max_clients_per_address: 1\n    stale_after_ms: 2000\n    control_clients: ['::1', 127.0.0.1]\n");
  const auto r = parseCellConfig(y, "cell.yaml");
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_EQ(r->robots.front().maxClientsPerAddress, 1);
  EXPECT_EQ(r->robots.front().staleAfterMs, 2000);
  EXPECT_EQ(r->robots.front().controlClients, (std::vector<std::string>{"::1", "127.0.0.1"}));
  std::string bad = embeddedSimCellYaml();
  bad.insert(bad.find("    reply_deadline_ms: 1500         # below URScript"), "    stale_after_ms: 10\n");
  EXPECT_FALSE(parseCellConfig(bad, "cell.yaml").has_value());
}

TEST(connection_limits_config, JournalKeys) {
  const auto d = parseCellConfig(embeddedSimCellYaml(), "sim-cell.yaml");
  ASSERT_TRUE(d.has_value());
  EXPECT_EQ(d->journalMaxBytes, 100LL << 20);
  EXPECT_EQ(d->journalFiles, 9);
  EXPECT_EQ(d->journalSyncMs, 1000);
  std::string y = embeddedSimCellYaml();
  const auto at = y.find("  log_level: info");
  y.insert(at, "  journal_max_bytes: 1048576\n  journal_files: 3\n  journal_sync_ms: 0\n");
  const auto c = parseCellConfig(y, "cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_EQ(c->journalMaxBytes, 1048576);
  EXPECT_EQ(c->journalFiles, 3);
  EXPECT_EQ(c->journalSyncMs, 0);
  std::string bad = embeddedSimCellYaml();
  bad.insert(bad.find("  log_level: info"), "  journal_max_bytes: 100\n");
  const auto e = parseCellConfig(bad, "cell.yaml");
  ASSERT_FALSE(e.has_value());
  EXPECT_NE(e.error().message.find("cell.journal_max_bytes"), std::string::npos) << e.error().message;
}

}  // namespace
}  // namespace vgr::config
