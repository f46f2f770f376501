// The command-line conventions of core/cli.hpp, held by every program we ship (docs/plant.md,
// "Exit codes and --help"): `--help` exits 0 and shows defaults; an unknown option or a
// missing required one exits 2 (bad input) with a message on stderr, never CLI11's own
// 105..127. Every `vgr` subcommand is found from `vgr --help` and its groups' help, so a new
// subcommand is covered without editing this test.
#include <gtest/gtest.h>

#include <regex>
#include <set>
#include <sstream>
#include <string>
#include <vector>

#include "tests/support/command.hpp"

namespace {

using vgr::test::binPath;
using vgr::test::runCommand;

// The names under "SUBCOMMANDS:" in a CLI11 help text.
std::vector<std::string> subcommandsIn(const std::string& help) {
  std::vector<std::string> out;
  std::istringstream in(help);
  std::string line;
  bool inList = false;
  const std::regex entry(R"(^  ([a-z][a-z0-9-]*)(\s|$))");
  while (std::getline(in, line)) {
    if (line.rfind("SUBCOMMANDS:", 0) == 0 || line.rfind("Subcommands:", 0) == 0) {
      inList = true;
      continue;
    }
    if (!inList) continue;
    std::smatch m;
    if (std::regex_search(line, m, entry))
      out.push_back(m[1]);
    else if (!line.empty() && line[0] != ' ')
      inList = false;
  }
  return out;
}

// Every runnable vgr command line prefix: "demo", "calibrate intrinsics", ... (found once).
const std::vector<std::string>& vgrCommands() {
  static const std::vector<std::string> commands = [] {
    const auto top = runCommand(binPath("vgr") + " --help");
    EXPECT_EQ(top.exitCode, 0) << top.err;
    std::vector<std::string> out;
    for (const auto& name : subcommandsIn(top.out)) {
      const auto help = runCommand(binPath("vgr") + " " + name + " --help");
      const auto children = subcommandsIn(help.out);
      if (children.empty()) out.push_back(name);
      for (const auto& c : children) out.push_back(name + " " + c);
    }
    return out;
  }();
  return commands;
}

TEST(CliConventions, EveryVgrSubcommandIsFound) {
  const auto cmds = vgrCommands();
  const std::set<std::string> found(cmds.begin(), cmds.end());
  for (const char* expected : {"demo", "check", "grab", "calibrate intrinsics", "calibrate handeye", "sim render",
                               "teach", "locate", "eval", "classify train"})
    EXPECT_TRUE(found.count(expected)) << expected << " not found in vgr --help";
}

TEST(CliConventions, HelpExitsZeroAndShowsDefaults) {
  for (const auto& cmd : vgrCommands()) {
    const auto r = runCommand(binPath("vgr") + " " + cmd + " --help");
    EXPECT_EQ(r.exitCode, 0) << "vgr " << cmd << " --help\n" << r.err;
    EXPECT_NE(r.out.find("--help"), std::string::npos) << "vgr " << cmd;
  }
  // A subcommand with numeric defaults shows them (CLI11: "--cycles INT=50" or "[50]").
  const auto demo = runCommand(binPath("vgr") + " demo --help");
  EXPECT_TRUE(std::regex_search(demo.out, std::regex(R"(--cycles[^\n]*(=|\[)[0-9]+)"))) << demo.out;
  const auto vgrd = runCommand(binPath("vgrd") + " --help");
  EXPECT_EQ(vgrd.exitCode, 0);
  EXPECT_NE(vgrd.out.find("/etc/vgr/cell.yaml"), std::string::npos) << vgrd.out;  // --config's default
}

TEST(CliConventions, AnUnknownOptionIsBadInputEverywhere) {
  std::vector<std::string> lines;
  for (const auto& cmd : vgrCommands()) lines.push_back(binPath("vgr") + " " + cmd);
  for (const char* p : {"vgrd", "vgr-sim-camera", "vgr-sim-plc", "vgr-sim-robot"}) lines.push_back(binPath(p));
  for (const auto& line : lines) {
    const auto r = runCommand(line + " --no-such-option-xyz", std::chrono::milliseconds(30000));
    EXPECT_EQ(r.exitCode, 2) << line << "\n" << r.out << r.err;
    // The message names the option, or first a required option that is missing (CLI11
    // checks those before extras): either way one line on stderr says what is wrong.
    EXPECT_FALSE(r.err.empty()) << line;
  }
}

TEST(CliConventions, AMissingRequiredOptionIsBadInput) {
  // Commands that cannot run without an option: the parse fails and says which.
  for (const char* cmd : {"locate", "teach", "eval", "sim render", "calibrate intrinsics"}) {
    const auto r = runCommand(binPath("vgr") + " " + cmd, std::chrono::milliseconds(30000));
    EXPECT_EQ(r.exitCode, 2) << "vgr " << cmd << "\n" << r.out << r.err;
    EXPECT_FALSE(r.err.empty()) << "vgr " << cmd;
  }
  const auto robot = runCommand(binPath("vgr-sim-robot"), std::chrono::milliseconds(30000));
  EXPECT_EQ(robot.exitCode, 2) << robot.err;  // --dialect and --port are required
}

}  // namespace
