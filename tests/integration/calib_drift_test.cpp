// Calibration checks on the simulated cell (docs/calibration.md, "Checking a calibration"):
// a fiducial glued on the belt (sim.fiducial) and a still check part (sim.still, job 1).
//  1. `vgr calibrate verify --store` measures both through the cell's calibration files and
//     writes check.yaml (the fiducial lands within 0.1 mm of where the renderer put it);
//  2. verify passes on the undisturbed cell; vgrd's drift monitor stays quiet for 10 cycles;
//  3. the camera knocked 0.5 mm (sim.camera_shift, calibration unchanged): verify fails
//     (exit 1, both targets ~0.5 mm off), vgrd's drift monitor raises its alarm within ten
//     cycles: journal drift_alarm, the log line, /metrics vgr_calibration_drift_alarm 1;
//     with on_alarm: refuse the cycles after the alarm answer -6 NOT_CALIBRATED.
#include <gtest/gtest.h>

#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <fstream>
#include <regex>
#include <string>
#include <thread>

#include <modbus.h>
#include <nlohmann/json.hpp>

#include "sim/cell_scenes.hpp"
#include "tests/support/command.hpp"
#include "tests/support/modbus_cell.hpp"
#include "tests/support/raw_tcp_client.hpp"
#include "vision/calib/check_file.hpp"
#include "vision/calib/plane_model.hpp"

namespace {

using namespace std::chrono_literals;
using nlohmann::json;

class calib_drift : public vgr::test::ModbusCell {
 protected:
  // The example cell with a still part, the fiducial, /metrics on a free port, and `extra`
  // appended to the calibration section.
  std::string cellYaml(const std::string& simExtra, const std::string& calibExtra) {
    std::string y = vgr::config::embeddedSimCellYaml();
    const std::string sim = "\nsim:\n", plane = "  plane: sim-calib/plane.yaml\n";
    const auto s = y.find(sim);
    EXPECT_NE(s, std::string::npos);
    if (s != std::string::npos) y.insert(s + sim.size(), "  still: true\n  fiducial: {x_mm: 600, y_mm: 250, diameter_mm: 12}\n" + simExtra);
    const auto p = y.find(plane);
    EXPECT_NE(p, std::string::npos);
    if (p != std::string::npos) y.insert(p + plane.size(), calibExtra);
    return y + "\nweb: {bind: 127.0.0.1, port: " + std::to_string(webPort_) + "}\n";
  }
  // The journal once it holds `n` lines (vgrd answers the PLC before it writes the line),
  // waiting up to 3 s; what it holds then.
  std::vector<json> journalOf(std::size_t n) {
    auto lines = journal();
    for (int i = 0; i < 150 && lines.size() < n; ++i) {
      std::this_thread::sleep_for(20ms);
      lines = journal();
    }
    return lines;
  }
  void rewrite(const std::string& yaml) { std::ofstream(configPath_) << yaml; }
  std::string verify(const std::string& args, int& exit) {
    const auto r = vgr::test::runVgr("calibrate verify --config " + configPath_ + " " + args);
    exit = r.exitCode;
    return r.out;
  }
  // `n` PLC cycles; their ERROR_CODEs.
  std::vector<int> cycles(int n, std::uint16_t first) {
    std::vector<int> codes;
    modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
    EXPECT_EQ(modbus_connect(ctx), 0);
    for (int k = 0; k < n; ++k) codes.push_back(static_cast<std::int16_t>(triggerCounter(ctx, static_cast<std::uint16_t>(first + k), 3000ms).error));
    modbus_close(ctx);
    modbus_free(ctx);
    return codes;
  }
  double metric(const std::string& name) {
    const std::string m = vgr::test::httpRequest(webPort_, "GET", "/metrics");
    std::smatch s;
    if (!std::regex_search(m, s, std::regex("\n" + name + " ([^\n]+)"))) return -1e9;
    return std::stod(s[1]);
  }
  std::uint16_t webPort_ = vgr::test::freeLoopbackPort();
};

TEST_F(calib_drift, KnockedCameraFailsVerifyAndRaisesTheDriftAlarm) {
  ASSERT_NO_FATAL_FAILURE(prepareCell([&](std::string) { return cellYaml("", ""); }));
  ASSERT_NO_FATAL_FAILURE(startCamera());
  // Where the nominal camera sees the fiducial: an 80 px window around it.
  const auto& m = cfg_.model;
  const vgr::vision::PinholePlaneModel cam(m.fx, m.fy, m.cx, m.cy,
                                           vgr::vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg), m.planeZ);
  const auto px = cam.project({600, 250, 0});
  ASSERT_TRUE(px);
  const std::string window = std::to_string(static_cast<int>(px->u) - 40) + "," + std::to_string(static_cast<int>(px->v) - 40) + ",80,80";
  const std::string checkPath = (dir_ / "check.yaml").string();

  // 1. Store the check targets right after calibration.
  int exit = 0;
  std::string out = verify("--check " + checkPath + " --store --fiducial-window " + window + " --part-job 1 --frames 3 --json", exit);
  ASSERT_EQ(exit, 0) << out;
  auto stored = vgr::vision::calib::readCheckFile(checkPath);
  ASSERT_TRUE(stored) << stored.error().message;
  EXPECT_NEAR(stored->fiducial.positionMm.x, 600, 0.1);
  EXPECT_NEAR(stored->fiducial.positionMm.y, 250, 0.1);
  EXPECT_NEAR(stored->fiducial.positionMm.z, 0, 0.1);
  const auto truth = vgr::sim::CellScenes(cfg_).truth(1);
  EXPECT_NEAR(stored->part.xMm, truth[0].xMm, 0.2);
  EXPECT_NEAR(stored->part.yMm, truth[0].yMm, 0.2);

  // 2. The undisturbed cell: verify passes (the check file named in the config), no alarm.
  const std::string monitor = "  check: check.yaml\n  drift: {threshold_mm: 0.3, window: 5}\n";
  rewrite(cellYaml("", monitor));
  out = verify("--json", exit);
  ASSERT_EQ(exit, 0) << out;
  json j = json::parse(vgr::test::lastLine(out));
  EXPECT_TRUE(j["pass"].get<bool>());
  EXPECT_LT(j["checks"][0]["off_mm"].get<double>(), 0.05) << out;
  EXPECT_LT(j["checks"][1]["off_mm"].get<double>(), 0.05) << out;
  ASSERT_NO_FATAL_FAILURE(startVgrd());
  EXPECT_EQ(cycles(10, 1), std::vector<int>(10, 0));
  double quiet = 0;
  const auto first = journalOf(10);
  EXPECT_EQ(first.size(), 10u);
  for (const auto& line : first) {
    EXPECT_FALSE(line["drift_alarm"].get<bool>()) << line.dump();
    EXPECT_LT(line["drift_mm"].get<double>(), 0.1) << line.dump();
    quiet = std::max(quiet, line["drift_mm"].get<double>());
  }
  std::printf("undisturbed: verify off by %.3f mm (fiducial) / %.3f mm, %.3f deg (part); drift at most %.3f mm in 10 cycles\n",
              j["checks"][0]["off_mm"].get<double>(), j["checks"][1]["off_mm"].get<double>(),
              j["checks"][1]["off_deg"].get<double>(), quiet);
  EXPECT_EQ(metric("vgr_calibration_drift_alarm"), 0);
  EXPECT_LT(metric("vgr_calibration_drift_mm"), 0.1);
  EXPECT_GE(metric("vgr_calibration_age_seconds\\{file=\"check\",path=\"" + checkPath + "\"\\}"), 0);
  vgrd_.reset();
  const std::size_t undisturbed = journal().size();

  // 3. The camera knocked 0.5 mm; the calibration files unchanged.
  camera_.reset();
  rewrite(cellYaml("  camera_shift: {x_mm: 0.5}\n", monitor));
  ASSERT_NO_FATAL_FAILURE(startCamera());
  out = verify("--json", exit);
  EXPECT_EQ(exit, 1) << out;
  j = json::parse(vgr::test::lastLine(out));
  EXPECT_FALSE(j["pass"].get<bool>());
  for (const auto& c : j["checks"]) {
    EXPECT_FALSE(c["pass"].get<bool>()) << c.dump();
    EXPECT_NEAR(c["off_mm"].get<double>(), 0.5, 0.1) << c.dump();
  }
  out = verify("", exit);
  EXPECT_NE(out.find("vgr calibrate verify: FAIL (2 of 2 check(s))"), std::string::npos) << out;

  ASSERT_NO_FATAL_FAILURE(startVgrd());
  EXPECT_EQ(cycles(10, 100), std::vector<int>(10, 0));  // on_alarm: warn keeps delivering
  const auto lines = journalOf(undisturbed + 10);
  ASSERT_EQ(lines.size(), undisturbed + 10);
  int firstAlarm = 0;
  for (std::size_t k = undisturbed; k < lines.size(); ++k) {
    EXPECT_NEAR(lines[k]["drift_mm"].get<double>(), 0.5, 0.1) << lines[k].dump();
    if (lines[k]["drift_alarm"].get<bool>() && firstAlarm == 0) firstAlarm = static_cast<int>(k - undisturbed + 1);
  }
  EXPECT_GE(firstAlarm, 1);
  EXPECT_LE(firstAlarm, 10) << "the alarm within ten cycles";
  std::printf("camera knocked 0.5 mm: drift %.3f mm, alarm at cycle %d of 10; verify off by %.3f mm (fiducial) / %.3f mm (part)\n",
              lines.back()["drift_mm"].get<double>(), firstAlarm, j["checks"][0]["off_mm"].get<double>(),
              j["checks"][1]["off_mm"].get<double>());
  EXPECT_NE(log("vgrd.log").find("calibration drift ALARM"), std::string::npos) << log("vgrd.log");
  EXPECT_EQ(metric("vgr_calibration_drift_alarm"), 1);
  EXPECT_NEAR(metric("vgr_calibration_drift_mm"), 0.5, 0.1);
  // The commissioning page's status carries the monitor's state and why the alarm is up.
  const std::string reply = vgr::test::httpRequest(webPort_, "GET", "/api/status");
  const auto body = reply.find("\r\n\r\n");
  ASSERT_NE(body, std::string::npos) << reply;
  const json status = json::parse(reply.substr(body + 4), nullptr, false);
  ASSERT_TRUE(status.is_object());
  const json& drift = status["sections"]["drift"];
  EXPECT_TRUE(drift.value("alarm", false)) << status.dump();
  EXPECT_NEAR(drift.value("median_mm", 0.0), 0.5, 0.1) << drift.dump();
  EXPECT_EQ(drift.value("frames_seen", 0), 10) << drift.dump();
  EXPECT_EQ(drift.value("on_alarm", ""), "warn");
  EXPECT_NE(drift.value("reason", "").find("median residual"), std::string::npos) << drift.dump();
  vgrd_.reset();

  // on_alarm: refuse: once the alarm is up, every cycle answers -6 NOT_CALIBRATED.
  rewrite(cellYaml("  camera_shift: {x_mm: 0.5}\n", "  check: check.yaml\n  drift: {threshold_mm: 0.3, window: 5, on_alarm: refuse}\n"));
  ASSERT_NO_FATAL_FAILURE(startVgrd());
  EXPECT_EQ(cycles(5, 200), (std::vector<int>{0, 0, -6, -6, -6}));
}

}  // namespace
