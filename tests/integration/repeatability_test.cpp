// `vgr repeatability` (tools/vgr/repeatability.hpp, docs/commissioning.md): on the simulated
// cell with a still part (sim.still: the part does not move, the sensor noise changes per
// frame) 100 live triggers through vgrd's Modbus server spread by at most 0.02 mm / 0.01 deg,
// around the renderer's truth; on replayed frames the same; a moving part fails the bar.
#include <gtest/gtest.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "core/angles.hpp"
#include "sim/cell_scenes.hpp"
#include "tests/support/command.hpp"
#include "tests/support/modbus_cell.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace {

using nlohmann::json;

// The sim section gets `still: true`.
std::string still(std::string yaml) {
  const std::string key = "\nsim:\n";
  const auto at = yaml.find(key);
  EXPECT_NE(at, std::string::npos);
  if (at != std::string::npos) yaml.insert(at + key.size(), "  still: true\n");
  return yaml;
}

class repeatability : public vgr::test::ModbusCell {
 protected:
  // The still cell with its page on (web.actions stay off: recording a run is not an action).
  std::string withPage(std::string yaml) { return still(std::move(yaml)) + "\nweb: {bind: 127.0.0.1, port: " + std::to_string(webPort_) + "}\n"; }
  // sections.repeatability of /api/status; null when the page did not answer.
  json pageSection() {
    const std::string reply = vgr::test::httpRequest(webPort_, "GET", "/api/status");
    const auto body = reply.find("\r\n\r\n");
    if (body == std::string::npos) return nullptr;
    const json st = json::parse(reply.substr(body + 4), nullptr, false);
    return st.is_object() && st.contains("sections") ? st["sections"].value("repeatability", json()) : json();
  }
  std::uint16_t webPort_ = vgr::test::freeLoopbackPort();
};

TEST_F(repeatability, HundredLiveShotsOfAStillPartMeetTheBarAndAppearOnThePage) {
  ASSERT_NO_FATAL_FAILURE(startCell([this](std::string y) { return withPage(std::move(y)); }));
  // Before any run the page says so (and where a run would be kept).
  json sec = pageSection();
  ASSERT_TRUE(sec.is_object()) << sec.dump();
  EXPECT_TRUE(sec.contains("state")) << sec.dump();
  EXPECT_FALSE(sec.contains("x_mm")) << sec.dump();
  const auto r = vgr::test::runVgr("repeatability --config " + configPath_ +
                                   " --shots 100 --max-sigma-mm 0.02 --max-sigma-deg 0.01 --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const json j = json::parse(vgr::test::lastLine(r.out));
  EXPECT_TRUE(j.value("recorded", false)) << r.out;
  EXPECT_EQ(j["source"], "live");
  EXPECT_EQ(j["shots"], 100);
  EXPECT_EQ(j["found"], 100);
  EXPECT_EQ(j["failed"], 0);
  for (const char* axis : {"x_mm", "y_mm", "z_mm"}) EXPECT_LE(j[axis]["sigma"].get<double>(), 0.02) << axis;
  for (const char* axis : {"rx_deg", "ry_deg", "rz_deg"}) EXPECT_LE(j[axis]["sigma"].get<double>(), 0.01) << axis;
  // The noise moves it at all (the tool measures, it does not read one value 100 times) ...
  EXPECT_GT(j["x_mm"]["range"].get<double>() + j["y_mm"]["range"].get<double>(), 0.0);
  // ... around where the part is.
  const auto truth = vgr::sim::CellScenes(cfg_).truth(1);
  ASSERT_EQ(truth.size(), 1u);
  EXPECT_NEAR(j["x_mm"]["mean"].get<double>(), truth[0].xMm, 0.2);
  EXPECT_NEAR(j["y_mm"]["mean"].get<double>(), truth[0].yMm, 0.2);
  EXPECT_LT(vgr::angleDiffDeg(j["rz_deg"]["mean"].get<double>(), truth[0].rzDeg), 0.2);
  std::printf("100 shots: sigma x %.4f y %.4f z %.4f mm, rz %.4f deg; max-min x %.4f y %.4f mm, rz %.4f deg\n",
              j["x_mm"]["sigma"].get<double>(), j["y_mm"]["sigma"].get<double>(), j["z_mm"]["sigma"].get<double>(),
              j["rz_deg"]["sigma"].get<double>(), j["x_mm"]["range"].get<double>(), j["y_mm"]["range"].get<double>(),
              j["rz_deg"]["range"].get<double>());

  // The same figures on the page, exactly (the tool sends them in their shortest exact form).
  sec = pageSection();
  ASSERT_TRUE(sec.is_object()) << sec.dump();
  for (const char* axis : {"x_mm", "y_mm", "z_mm", "rx_deg", "ry_deg", "rz_deg"})
    for (const char* f : {"mean", "sigma", "range"})
      EXPECT_EQ(sec[axis][f].get<double>(), j[axis][f].get<double>()) << axis << "." << f << " " << sec.dump();
  EXPECT_EQ(sec["shots"], 100);
  EXPECT_EQ(sec["found"], 100);
  EXPECT_EQ(sec["pass"], true);
  EXPECT_EQ(sec["max_sigma_mm"].get<double>(), j["max_sigma_mm"].get<double>());
  EXPECT_EQ(sec["bar_mm"].get<double>(), 0.02);
  EXPECT_EQ(sec["from"], "127.0.0.1");
  // Kept beside the journal: a restarted vgrd shows the same run.
  const std::string file = (std::filesystem::path(journalPath()).parent_path() / "repeatability.json").string();
  EXPECT_EQ(sec["file"], file);
  ASSERT_TRUE(std::filesystem::exists(file));
  vgrd_.reset();
  ASSERT_NO_FATAL_FAILURE(startVgrd());
  const json again = pageSection();
  ASSERT_TRUE(again.is_object());
  EXPECT_EQ(again["x_mm"], sec["x_mm"]) << again.dump();
  EXPECT_EQ(again["at"], sec["at"]);

  // What vgrd refuses: no header; figures that contradict themselves; a job it does not have.
  const std::string good = "job=1&shots=3&found=3&failed=0&x_mm=1,0.01,0.02&y_mm=2,0.01,0.02&z_mm=3,0,0"
                           "&rx_deg=0,0,0&ry_deg=0,0,0&rz_deg=10,0.001,0.002&bar_mm=0&bar_deg=0&pass=1";
  auto post = [this](const std::string& q, bool header) {
    return vgr::test::httpRequest(webPort_, "POST", "/api/repeatability?" + q, std::chrono::milliseconds(5000),
                                  header ? "X-Vgr-Action: 1\r\nContent-Length: 0\r\n" : "Content-Length: 0\r\n");
  };
  EXPECT_EQ(post(good, false).rfind("HTTP/1.1 403", 0), 0u);
  std::string bad = good;
  bad.replace(bad.find("found=3"), 7, "found=2");
  EXPECT_EQ(post(bad, true).rfind("HTTP/1.1 400", 0), 0u);
  bad = good;
  bad.replace(bad.find("x_mm=1,0.01"), 11, "x_mm=1,-0.01");
  EXPECT_EQ(post(bad, true).rfind("HTTP/1.1 400", 0), 0u);
  bad = good;
  bad.replace(0, 5, "job=9");
  EXPECT_EQ(post(bad, true).rfind("HTTP/1.1 400", 0), 0u);
  bad = good;
  bad.replace(bad.find("bar_mm=0"), 8, "bar_mm=0.001");  // sigma 0.01 over the bar with pass=1
  EXPECT_EQ(post(bad, true).rfind("HTTP/1.1 400", 0), 0u);
  EXPECT_EQ(pageSection()["x_mm"], sec["x_mm"]) << "a refused record changed the page";
  EXPECT_EQ(post(good, true).rfind("HTTP/1.1 200", 0), 0u);
  EXPECT_EQ(pageSection()["shots"], 3);

  // A record file that does not read is reported, never shown as figures.
  vgrd_.reset();
  std::ofstream(file) << "{\"job\": 1, \"shots\": 100}\n";
  ASSERT_NO_FATAL_FAILURE(startVgrd());
  const json broken = pageSection();
  EXPECT_TRUE(broken.contains("error")) << broken.dump();
  EXPECT_FALSE(broken.contains("x_mm")) << broken.dump();
}

// A cell without a page: the run is measured and says it was not recorded.
TEST_F(repeatability, WithoutAPageTheRunSaysItIsNotRecorded) {
  ASSERT_NO_FATAL_FAILURE(startCell(still));
  const auto r = vgr::test::runVgr("repeatability --config " + configPath_ + " --shots 5");
  EXPECT_EQ(r.exitCode, 0) << r.out;
  EXPECT_NE(r.out.find("not recorded: the cell has no page"), std::string::npos) << r.out;
}

// Replayed frames, in-process: no cell, no ports.
TEST(repeatability_replay, StillFramesPassAMovingPartFails) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("vgr-repeat-" + std::to_string(::getpid()));
  fs::create_directories(dir / "still");
  fs::create_directories(dir / "moving");
  const std::string yaml = still(vgr::config::embeddedSimCellYaml());
  auto cfgPath = vgr::config::writeSimCell(dir.string(), yaml);
  ASSERT_TRUE(cfgPath);
  auto cfg = vgr::config::parseCellConfig(yaml, "cell.yaml");
  ASSERT_TRUE(cfg);
  const vgr::sim::CellScenes stillScenes(*cfg);
  cfg->sim.still = false;
  const vgr::sim::CellScenes moving(*cfg);
  cv::Mat img;
  for (int k = 1; k <= 12; ++k) {
    stillScenes.render(static_cast<std::uint64_t>(k), img);
    ASSERT_TRUE(cv::imwrite((dir / "still" / (std::to_string(100 + k) + ".png")).string(), img));
    moving.render(static_cast<std::uint64_t>(k), img);
    ASSERT_TRUE(cv::imwrite((dir / "moving" / (std::to_string(100 + k) + ".png")).string(), img));
  }
  auto r = vgr::test::runVgr("repeatability --config " + *cfgPath + " --images '" + (dir / "still").string() +
                             "/*.png' --max-sigma-mm 0.02 --max-sigma-deg 0.01 --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  json j = json::parse(vgr::test::lastLine(r.out));
  EXPECT_EQ(j["source"], "replay");
  EXPECT_EQ(j["found"], 12);
  EXPECT_LE(j["x_mm"]["sigma"].get<double>(), 0.02);
  const auto truth = stillScenes.truth(1);
  EXPECT_NEAR(j["x_mm"]["mean"].get<double>(), truth[0].xMm, 0.2);

  r = vgr::test::runVgr("repeatability --config " + *cfgPath + " --images '" + (dir / "moving").string() +
                        "/*.png' --max-sigma-mm 0.02 --max-sigma-deg 0.01 --json");
  EXPECT_EQ(r.exitCode, 1) << r.out;
  j = json::parse(vgr::test::lastLine(r.out));
  EXPECT_FALSE(j["pass"].get<bool>());
  EXPECT_GT(j["x_mm"]["sigma"].get<double>(), 10.0);

  // Bad input: exit 2 with the reason.
  r = vgr::test::runVgr("repeatability --config " + *cfgPath + " --images '" + (dir / "none").string() + "/*.png'");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_NE(r.out.find("no file matches"), std::string::npos) << r.out;
  r = vgr::test::runVgr("repeatability --config " + *cfgPath + " --job 9 --shots 5");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
