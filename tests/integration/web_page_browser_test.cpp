// The commissioning page (docs/commissioning.md) in a real browser: the simulated cell with
// a `web` section (operator actions on, allowed only from 127.0.0.2) and an archive, every
// 4th frame an empty belt; tests/browser/page_check.mjs drives Debian's chromium through
// playwright-core (npm, /usr/bin/chromium: no browser download) while this test triggers PLC
// cycles over Modbus. The script checks on the canvas's pixels that each new cycle's overlay
// is up within 1 s of the cycle (of its result), that the cycles table equals the journal, and that the
// page's trigger from 127.0.0.1 is refused (403) while the same POST from 127.0.0.2 runs.
// Its JSON report is checked here. VGR_WEB_SHOTS=DIR also writes the page's screenshots
// to DIR (docs/img/ was made so).
// The same on the simulated 3D cell (config/examples/sim-cell-3d.yaml, robot triggers):
// each 3D cycle's picture is its depth frame in false colour (docs/3d.md "The page's depth
// picture"), with the disc at the journal's grasp point, the stated z range and the colour
// bar (page_check.mjs --depth 1).
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <string>
#include <filesystem>
#include <fstream>

#include "depth_cell.hpp"
#include "modbus_cell.hpp"
#include "tests/support/command.hpp"
#include "tests/support/raw_tcp_client.hpp"
#include "tools/vgr/demo3d.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

// Node and tests/browser/page_check.mjs, after checking that playwright-core and Debian's
// chromium are installed.
void browserScript(std::string& node, std::string& script) {
  node = std::filesystem::exists("/usr/bin/node") ? "/usr/bin/node" : "node";
  script = vgr::test::sourcePath("tests/browser/page_check.mjs");
  ASSERT_TRUE(std::filesystem::exists(vgr::test::sourcePath("tests/browser/node_modules/playwright-core/package.json")))
      << "playwright-core is not installed: scripts/install-deps.sh runs 'npm ci' in tests/browser";
  ASSERT_TRUE(std::filesystem::exists("/usr/bin/chromium")) << "Debian's chromium: scripts/install-deps.sh installs it";
}

// The script's JSON report (its last '{' line) once it has exited, with what every run must
// hold: a report, no failures, exit 0, a latency for each of the `checked` cycles.
// `browserLog` reads the script's log (for the failure messages).
void finishedReport(vgr::test::ChildProcess& p, int checked, const std::function<std::string()>& browserLog,
                    nlohmann::json& j) {
  std::string report;
  for (auto line = p.readLine(60s); line; line = p.readLine(60s))
    if (!line->empty() && line->front() == '{') report = *line;
  const int rc = p.wait(10s);
  j = nlohmann::json::parse(report, nullptr, false);
  ASSERT_TRUE(j.is_object()) << "no report from the browser script\n" << browserLog();
  std::printf("browser: %s\n", report.c_str());
  EXPECT_TRUE(j["failures"].empty()) << j["failures"].dump(2) << "\n" << browserLog();
  EXPECT_EQ(rc, 0) << browserLog();
  ASSERT_GE(j["latencies_after_result_ms"].size(), static_cast<std::size_t>(checked));
}

class web_page_browser : public ModbusCell {};

TEST_F(web_page_browser, NewCycleOverlayWithinASecondTableEqualsJournalOutsiderRefused) {
  std::string node, script;
  ASSERT_NO_FATAL_FAILURE(browserScript(node, script));

  const int port = vgr::test::freeLoopbackPort();
  ASSERT_GT(port, 0);
  ASSERT_NO_FATAL_FAILURE(prepareCell([port](std::string yaml) {
    return yaml + "\nweb:\n  bind: 127.0.0.1\n  port: " + std::to_string(port) +
           "\n  actions: true\n  allowed_clients: [127.0.0.2]\narchive:\n  quota_mb: 20\n  every_nth_good: 3\n";
  }));
  camera_ = vgr::test::startEmulator({"--config", configPath_, "--empty-every", "4"}, (dir_ / "camera.log").string());
  ASSERT_NE(camera_, nullptr);
  ASSERT_NO_FATAL_FAILURE(startVgrd());

  const char* shotsEnv = std::getenv("VGR_WEB_SHOTS");
  const std::string shots = shotsEnv ? shotsEnv : (dir_ / "shots").string();
  constexpr int kChecked = 5;
  auto p = vgr::test::ChildProcess::spawn({node, script, "--url", "http://127.0.0.1:" + std::to_string(port) + "/", "--journal",
                                           journalPath(), "--cycles", std::to_string(kChecked), "--allowed", "127.0.0.2",
                                           "--shots", shots},
                                          (dir_ / "browser.log").string());
  ASSERT_TRUE(p.has_value());
  ASSERT_TRUE(p->waitForLine("READY", 60s)) << log("browser.log") << log("vgrd.log");

  // PLC cycles, 700 ms apart: every 4th frame is an empty belt (NO_PART_FOUND), so 10
  // cycles give the script its 5 OK ones to check and a few failures to show.
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  for (int i = 1; i <= 10; ++i) {
    const auto r = triggerCounter(ctx, static_cast<std::uint16_t>(500 + i), 5s);
    EXPECT_TRUE(r.status & 0x08) << "RESULT_VALID, cycle " << i;
    std::this_thread::sleep_for(700ms);
  }
  modbus_close(ctx);
  modbus_free(ctx);

  nlohmann::json j;
  ASSERT_NO_FATAL_FAILURE(finishedReport(*p, kChecked, [this] { return log("browser.log"); }, j));
  for (const auto& l : j["latencies_after_result_ms"]) EXPECT_LT(l.get<double>(), 1000.0) << "cycle's result -> overlay on the canvas";
  EXPECT_GE(j["rows_checked"].get<int>(), kChecked);
  EXPECT_EQ(j["refused_status"], 403);
  EXPECT_EQ(j["allowed_status"], 200);
  EXPECT_EQ(j["allowed_without_header_status"], 403);
  EXPECT_EQ(j["operator_cycles"], 1);
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(shots) / "commissioning-page.png"));
  EXPECT_NE(log("vgrd.log").find("operator trigger refused: 127.0.0.1 is not in web.allowed_clients"), std::string::npos)
      << log("vgrd.log");
}

class web_page_browser_3d : public vgr::test::DepthCell {};

TEST_F(web_page_browser_3d, EachDepthPictureOnTheCanvasWithinASecondTableEqualsJournal) {
  std::string node, script;
  ASSERT_NO_FATAL_FAILURE(browserScript(node, script));

  // Scene 0 of seed 1 (the demo's first): one the localizer finds (docs/demo.md "3D").
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(1, vgr::tools::Demo3dScenes{}, 1));
  const int port = vgr::test::freeLoopbackPort();
  ASSERT_GT(port, 0);
  std::ofstream(configPath_, std::ios::app) << "\nweb:\n  bind: 127.0.0.1\n  port: " << port
                                            << "\n  actions: true\n  allowed_clients: [127.0.0.2]\n";
  ASSERT_NO_FATAL_FAILURE(start3dCell("Millimeter", true));

  const char* shotsEnv = std::getenv("VGR_WEB_SHOTS");
  const std::string shots = shotsEnv ? shotsEnv : (dir_ / "shots").string();
  constexpr int kChecked = 3;
  auto p = vgr::test::ChildProcess::spawn({node, script, "--url", "http://127.0.0.1:" + std::to_string(port) + "/", "--journal",
                                           journalPath(), "--cycles", std::to_string(kChecked), "--allowed", "127.0.0.2",
                                           "--shots", shots, "--depth", "1"},
                                          (dir_ / "browser.log").string());
  ASSERT_TRUE(p.has_value());
  ASSERT_TRUE(p->waitForLine("READY", 60s)) << log("browser.log") << log("vgrd.log");

  // Robot cycles (a 3D cell's robots trigger), 700 ms apart after each answer.
  vgr::test::RawTcpClient ur(kUrPort);
  for (int i = 1; i <= 2 * kChecked; ++i) {
    ASSERT_TRUE(ur.send("TRIG,1\n"));
    const auto reply = ur.readUntil(')', 40000ms);
    ASSERT_TRUE(reply) << log("vgrd.log");
    EXPECT_EQ(reply->rfind("(0,", 0), 0u) << "cycle " << i << ": " << *reply;
    std::this_thread::sleep_for(700ms);
  }

  nlohmann::json j;
  ASSERT_NO_FATAL_FAILURE(finishedReport(*p, kChecked, [this] { return log("browser.log"); }, j));
  for (const auto& l : j["latencies_after_result_ms"]) EXPECT_LT(l.get<double>(), 1000.0) << "cycle's result -> picture on the canvas";
  EXPECT_TRUE(j.contains("depth_mm")) << "the script checked no depth picture";
  EXPECT_GE(j["rows_checked"].get<int>(), kChecked);
  EXPECT_EQ(j["refused_status"], 403);
  EXPECT_EQ(j["allowed_status"], 200);
  EXPECT_EQ(j["operator_cycles"], 1);
  EXPECT_TRUE(std::filesystem::exists(std::filesystem::path(shots) / "commissioning-page-3d.png"));
}

}  // namespace
