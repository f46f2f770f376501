// vgrd's command line as an operator meets it: --check on good and broken configs, and a
// clear one-line error for a port that is already taken.

#include <algorithm>
#include <unistd.h>
#include <filesystem>
#include <fstream>
#include <string>

#include <gtest/gtest.h>

#include "config/cell_config.hpp"
#include "tests/support/command.hpp"

namespace {

namespace fs = std::filesystem;

using CmdRun = vgr::test::CommandResult;  // out: stdout + stderr

CmdRun run(const std::string& cmd) { return vgr::test::runCommand(cmd + " 2>&1"); }

std::string writeConfig(const std::string& name, const std::string& text) {
  const fs::path path = fs::temp_directory_path() / ("vgr-cli-" + std::to_string(::getpid()) + "-" + name);
  std::ofstream(path) << text;
  return path.string();
}

const std::string kVgrd = std::string(VGR_BIN_DIR) + "/vgrd";

TEST(VgrdCheck, ExampleConfigIsValid) {
  const CmdRun r = run(kVgrd + " --config " + VGR_SOURCE_DIR + "/config/examples/sim-cell.yaml --check");
  EXPECT_EQ(r.exitCode, 0) << r.out;
  EXPECT_NE(r.out.find(": ok"), std::string::npos) << r.out;
}

TEST(VgrdCheck, TypoGetsOneLineWithFileLineAndKey) {
  std::string text = vgr::config::embeddedSimCellYaml();
  const auto pos = text.find("  exposure_us: 5000");
  ASSERT_NE(pos, std::string::npos);
  text.replace(pos, 19, "  exposure_usec: 5000");
  const int line = 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(pos), '\n'));
  const std::string path = writeConfig("typo.yaml", text);
  const CmdRun r = run(kVgrd + " --config " + path + " --check");
  EXPECT_NE(r.exitCode, 0);
  EXPECT_EQ(r.out, "vgrd: " + path + ":" + std::to_string(line) +
                       ": key 'camera.exposure_usec': unknown key (did you mean 'exposure_us'?)\n");
  fs::remove(path);
}

TEST(VgrdCheck, MissingFileIsAnError) {
  const CmdRun r = run(kVgrd + " --config /nonexistent/cell.yaml --check");
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_EQ(r.out, "vgrd: /nonexistent/cell.yaml: cannot open the config file\n");
}

TEST(VgrdStart, PortInUseIsOneClearLine) {
  // Two robot endpoints cannot share a port (config check), but another program can hold
  // one: vgrd must say which endpoint and port, and exit non-zero.
  std::string text = vgr::config::embeddedSimCellYaml();
  const std::string path = writeConfig("ports.yaml", text);
  const CmdRun first = run("(" + kVgrd + " --config " + path + " --journal /tmp/vgr-cli-journal.jsonl & pid=$!; sleep 0.7; " + kVgrd +
                        " --config " + path + " --journal /tmp/vgr-cli-journal2.jsonl; rc=$?; kill $pid; wait $pid; exit $rc)");
  EXPECT_EQ(first.exitCode, 1) << first.out;
  EXPECT_NE(first.out.find("vgrd: "), std::string::npos) << first.out;
  EXPECT_NE(first.out.find("50010"), std::string::npos) << first.out;
  fs::remove(path);
  fs::remove("/tmp/vgr-cli-journal.jsonl");
  fs::remove("/tmp/vgr-cli-journal2.jsonl");
}

}  // namespace
