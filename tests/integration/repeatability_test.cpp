// `vgr repeatability` (tools/vgr/repeatability.hpp, docs/commissioning.md): on the simulated
// cell with a still part (sim.still: the part does not move, the sensor noise changes per
// frame) 100 live triggers through vgrd's Modbus server spread by at most 0.02 mm / 0.01 deg,
// around the renderer's truth; on replayed frames the same; a moving part fails the bar.
#include <gtest/gtest.h>

#include <filesystem>
#include <string>

#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "core/angles.hpp"
#include "sim/cell_scenes.hpp"
#include "tests/support/command.hpp"
#include "tests/support/modbus_cell.hpp"

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

class repeatability : public vgr::test::ModbusCell {};

TEST_F(repeatability, HundredLiveShotsOfAStillPartMeetTheBar) {
  ASSERT_NO_FATAL_FAILURE(startCell(still));
  const auto r = vgr::test::runVgr("repeatability --config " + configPath_ +
                                   " --shots 100 --max-sigma-mm 0.02 --max-sigma-deg 0.01 --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const json j = json::parse(vgr::test::lastLine(r.out));
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
