// Config loading: the example cell is valid; every kind of mistake names file:line and key.
#include <fstream>
#include <regex>
#include <string>

#include <gtest/gtest.h>

#include "config/cell_config.hpp"

namespace {

using vgr::config::parseCellConfig;

std::string example() { return vgr::config::embeddedSimCellYaml(); }

std::string replaceOnce(std::string text, const std::string& from, const std::string& to) {
  const auto pos = text.find(from);
  EXPECT_NE(pos, std::string::npos) << from;
  if (pos != std::string::npos) text.replace(pos, from.size(), to);
  return text;
}

int lineOf(const std::string& text, const std::string& needle) {
  const auto pos = text.find(needle);
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
}

TEST(CellConfig, ExampleIsValidAndTyped) {
  auto c = parseCellConfig(example(), "sim-cell.yaml");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_EQ(c->modbus.port, 1502);
  ASSERT_EQ(c->robots.size(), 3u);
  EXPECT_EQ(c->robots[0].port, 50010);
  EXPECT_EQ(c->robots[0].dialect, vgr::config::Dialect::Ur);
  EXPECT_EQ(c->robots[1].port, 50011);
  EXPECT_EQ(c->robots[1].dialect, vgr::config::Dialect::Abb);
  EXPECT_EQ(c->robots[2].port, 50012);
  EXPECT_EQ(c->robots[2].dialect, vgr::config::Dialect::Fanuc);
  EXPECT_EQ(c->camera.address, "127.0.0.1");
  ASSERT_NE(c->findJob(1), nullptr);
  EXPECT_EQ(c->findJob(2), nullptr);
}

TEST(CellConfig, ExampleFileOnDiskMatchesEmbedded) {
  std::ifstream in(std::string(VGR_SOURCE_DIR) + "/config/examples/sim-cell.yaml");
  std::string disk((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  EXPECT_EQ(disk, example());
}

TEST(CellConfig, TypoInKeyNamesFileLineAndSuggestion) {
  const std::string bad = replaceOnce(example(), "  timeout_ms: 1000", "  timout_ms: 1000");
  auto c = parseCellConfig(bad, "cell.yaml");
  ASSERT_FALSE(c.has_value());
  const std::string expected = "cell.yaml:" + std::to_string(lineOf(bad, "timout_ms")) +
                               ": key 'camera.timout_ms': unknown key (did you mean 'timeout_ms'?)";
  EXPECT_EQ(c.error().message, expected);
  EXPECT_EQ(c.error().message.find('\n'), std::string::npos);
}

TEST(CellConfig, WrongTypeAndRangeNameTheKey) {
  {
    const std::string bad = replaceOnce(example(), "  port: 1502", "  port: abc");
    auto c = parseCellConfig(bad, "cell.yaml");
    ASSERT_FALSE(c.has_value());
    EXPECT_EQ(c.error().message, "cell.yaml:" + std::to_string(lineOf(bad, "port: abc")) +
                                     ": key 'modbus.port': expected an integer in [1, 65535], got 'abc'");
  }
  {
    const std::string bad = replaceOnce(example(), "  exposure_us: 5000", "  exposure_us: 5");
    auto c = parseCellConfig(bad, "cell.yaml");
    ASSERT_FALSE(c.has_value());
    EXPECT_NE(c.error().message.find("key 'camera.exposure_us': out of range"), std::string::npos) << c.error().message;
  }
  {
    const std::string bad = replaceOnce(example(), "dialect: abb", "dialect: kuka");
    auto c = parseCellConfig(bad, "cell.yaml");
    ASSERT_FALSE(c.has_value());
    EXPECT_NE(c.error().message.find("key 'robots[1].dialect'"), std::string::npos) << c.error().message;
  }
}

TEST(CellConfig, DuplicatePortsAndMissingSectionsAreErrors) {
  auto dup = parseCellConfig(replaceOnce(example(), "port: 50011", "port: 50010"), "cell.yaml");
  ASSERT_FALSE(dup.has_value());
  EXPECT_NE(dup.error().message.find("port already used"), std::string::npos) << dup.error().message;

  auto noJobs = parseCellConfig("cell: {name: x}\ncamera: {address: 127.0.0.1}\nmodel: {fx: 1000}\n", "cell.yaml");
  ASSERT_FALSE(noJobs.has_value());
  EXPECT_NE(noJobs.error().message.find("key 'jobs': required key is missing"), std::string::npos) << noJobs.error().message;
}

TEST(CellConfig, SyntaxErrorNamesLine) {
  auto c = parseCellConfig("cell:\n  name: [unclosed\n", "broken.yaml");
  ASSERT_FALSE(c.has_value());
  EXPECT_TRUE(std::regex_search(c.error().message, std::regex("^broken\\.yaml:[0-9]+: YAML syntax error")))
      << c.error().message;
}

TEST(CellConfig, MissingFileIsAnError) {
  auto c = vgr::config::loadCellConfig("/nonexistent/cell.yaml");
  ASSERT_FALSE(c.has_value());
  EXPECT_EQ(c.error().message, "/nonexistent/cell.yaml: cannot open the config file");
}

}  // namespace
