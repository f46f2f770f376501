// Offsets and frames in the simulated cell (docs/protocols.md, "Offsets and frames"):
//  - robots in offset mode get the offset from the job's taught reference in their own
//    notation, and the unmodified example programs of examples/robot/ (RAPID PDispSet in a
//    work object, KAREL + TP Offset,PR[10] in UFRAME 1, URScript pose_trans), played by
//    vgr-sim-robot --program, move the tool onto the part the renderer placed;
//  - a part outside the job's limits gets -9 OFFSET_OUT_OF_LIMITS on every wire (PLC
//    registers, every robot, the journal with the reason) and is delivered to none.
// Real vgrd, camera emulator, Modbus (libmodbus) and robot simulators on loopback.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <string>
#include <thread>
#include <vector>

#include <unistd.h>

#include <modbus.h>
#include <nlohmann/json.hpp>

#include "core/angles.hpp"
#include "sim/cell_scenes.hpp"
#include "tests/support/command.hpp"
#include "tests/support/modbus_cell.hpp"

namespace {

using namespace std::chrono_literals;
using nlohmann::json;
using vgr::test::ChildProcess;

// The three robots in offset mode, in the frames the example programs were taught in
// (examples/robot/README.md).
const char* kOffsetRobots = R"(robots:
  - {name: ur5, dialect: ur, bind: 127.0.0.1, port: 50010, deliver: offset}
  - {name: irb, dialect: abb, bind: 127.0.0.1, port: 50011, deliver: offset,
     frame: {name: wConveyor, x_mm: 400, y_mm: -200, z_mm: 0, rz_deg: 90}}
  - {name: lrmate, dialect: fanuc, bind: 127.0.0.1, port: 50012, deliver: offset,
     frame: {name: UFRAME 1, x_mm: 250, y_mm: 150, z_mm: 0, rz_deg: 45}}
)";

std::string replaceSection(std::string yaml, const std::string& from, const std::string& to, const std::string& text) {
  const auto a = yaml.find(from), b = yaml.find(to, a);
  if (a == std::string::npos || b == std::string::npos) return "";
  return yaml.replace(a, b - a, text);
}

class robot_offsets : public vgr::test::ModbusCell {
 protected:
  // A robot simulator; its JSON lines are read by lines().
  void startRobot(const std::string& name, const std::string& dialect, int port, const std::vector<std::string>& program) {
    std::vector<std::string> argv = {bin("vgr-sim-robot"), "--dialect", dialect, "--port", std::to_string(port), "--name", name,
                                     "--count", "0", "--interval-ms", "0", "--json"};
    if (!program.empty()) {
      argv.insert(argv.end(), {"--config", configPath_});
      for (const auto& f : program) argv.insert(argv.end(), {"--program", vgr::test::sourcePath("examples/robot/" + f)});
    }
    auto p = ChildProcess::spawn(argv, (dir_ / (name + ".log")).string());
    ASSERT_TRUE(p.has_value());
    robots_.emplace(name, std::move(*p));
  }
  // Every reply line of each robot so far (summaries left out), after letting the last
  // result reach them.
  std::map<std::string, std::vector<json>> lines() {
    std::this_thread::sleep_for(300ms);
    std::map<std::string, std::vector<json>> out;
    for (auto& [name, p] : robots_)
      while (auto l = p.readLine(50ms)) {
        auto j = json::parse(*l, nullptr, false);
        if (j.is_object() && !j.contains("replies")) out[name].push_back(j);
      }
    return out;
  }
  // n PLC cycles in counter mode, `pause` apart (each result reaches every robot before the
  // next): {RESULT_ID, ERROR_CODE} each.
  std::vector<std::pair<std::uint32_t, int>> plcCycles(int n) {
    std::vector<std::pair<std::uint32_t, int>> out;
    modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
    if (!ctx || modbus_connect(ctx) != 0) {
      ADD_FAILURE() << "Modbus connect";
      if (ctx) modbus_free(ctx);
      return out;
    }
    for (int k = 0; k < n; ++k) {
      const auto r = triggerCounter(ctx, static_cast<std::uint16_t>(100 + k), 3000ms);
      EXPECT_TRUE(r.status & 0x08) << "RESULT_VALID, cycle " << k;
      out.emplace_back(r.resultId, static_cast<std::int16_t>(r.error));
      std::this_thread::sleep_for(150ms);
    }
    modbus_close(ctx);
    modbus_free(ctx);
    return out;
  }
  void TearDown() override {
    robots_.clear();
    ModbusCell::TearDown();
  }
  std::map<std::string, ChildProcess> robots_;
};

TEST_F(robot_offsets, ExampleProgramsApplyTheOffsetOntoThePart) {
  ASSERT_NO_FATAL_FAILURE(startCell([](std::string y) { return replaceSection(y, "\nrobots:\n", "\njobs:\n", std::string("\n") + kOffsetRobots); }));
  ASSERT_NO_FATAL_FAILURE(startRobot("ur5", "ur", kUrPort, {"vgr_offset.script"}));
  ASSERT_NO_FATAL_FAILURE(startRobot("irb", "abb", kAbbPort, {"VgrPick.mod"}));
  ASSERT_NO_FATAL_FAILURE(startRobot("lrmate", "fanuc", kFanucPort, {"vgr_bg.kl", "VGR_PICK.ls"}));
  std::this_thread::sleep_for(500ms);  // the robots connect (RAPID: JOB,1 first)
  const auto cycles = plcCycles(8);
  ASSERT_EQ(cycles.size(), 8u);
  const auto got = lines();
  const vgr::sim::CellScenes scenes(cfg_);
  for (const char* robot : {"ur5", "irb", "lrmate"}) {
    ASSERT_TRUE(got.count(robot)) << robot << " said nothing: " << log(std::string(robot) + ".log");
    int ok = 0;
    double worstMm = 0, worstDeg = 0;
    for (const auto& l : got.at(robot)) {
      ASSERT_TRUE(l.value("valid", false)) << robot << ": " << l.dump();
      if (l.value("status", -99) != 0) continue;
      ++ok;
      const json entry = journalEntry(l["cycle"].get<std::uint32_t>());
      ASSERT_TRUE(entry.is_object()) << l.dump();
      // The reply is the offset the journal lists for this robot, not the absolute pose.
      const auto& delivered = entry["robots"][robot]["poses"][0];
      EXPECT_NEAR(l["x_mm"].get<double>(), delivered[0].get<double>(), 1e-3) << robot << l.dump();
      EXPECT_NEAR(l["y_mm"].get<double>(), delivered[1].get<double>(), 1e-3) << robot << l.dump();
      EXPECT_GT(std::hypot(l["x_mm"].get<double>() - entry["parts"][0]["x_mm"].get<double>(),
                           l["y_mm"].get<double>() - entry["parts"][0]["y_mm"].get<double>()),
                1.0)
          << robot << ": got the absolute pose, not an offset: " << l.dump();
      // What the program does with it lands on the part: the journal's pose exactly ...
      EXPECT_NEAR(l["part_x_mm"].get<double>(), entry["parts"][0]["x_mm"].get<double>(), 0.005) << robot;
      EXPECT_NEAR(l["part_y_mm"].get<double>(), entry["parts"][0]["y_mm"].get<double>(), 0.005) << robot;
      EXPECT_LT(vgr::angleDiffDeg(l["part_rz_deg"].get<double>(), entry["parts"][0]["rz_deg"].get<double>()), 0.005) << robot;
      EXPECT_NEAR(l["part_rx_deg"].get<double>(), 0, 1e-3);
      EXPECT_NEAR(l["part_ry_deg"].get<double>(), 0, 1e-3);
      // ... and the renderer's truth within 0.2 mm / 0.2 deg.
      const auto truth = scenes.truth(entry["frame_id"].get<std::uint64_t>());
      ASSERT_EQ(truth.size(), 1u);
      worstMm = std::max(worstMm, std::hypot(l["part_x_mm"].get<double>() - truth[0].xMm, l["part_y_mm"].get<double>() - truth[0].yMm));
      worstDeg = std::max(worstDeg, vgr::angleDiffDeg(l["part_rz_deg"].get<double>(), truth[0].rzDeg));
    }
    EXPECT_EQ(ok, 8) << robot << " got an offset for every cycle";
    EXPECT_LT(worstMm, 0.2) << robot;
    EXPECT_LT(worstDeg, 0.2) << robot;
    std::printf("%s: %d offsets applied by the example program, worst %.3f mm / %.3f deg from the truth\n", robot, ok, worstMm,
                worstDeg);
  }
  // The journal names each robot's frame.
  const json last = journalEntry(cycles.back().first);
  EXPECT_EQ(last["robots"]["irb"]["frame"], "wConveyor");
  EXPECT_EQ(last["robots"]["lrmate"]["frame"], "UFRAME 1");
  EXPECT_EQ(last["robots"]["ur5"]["deliver"], "offset");
}

TEST_F(robot_offsets, PartsOutsideTheLimitsGetMinus9OnEveryWire) {
  // Work area x in [250, 450] and an offset rotation within +-90 deg: some frames of the
  // sim's random parts are inside, others outside (seed 1).
  ASSERT_NO_FATAL_FAILURE(startCell([](std::string y) {
    return replaceSection(y, "\njobs:\n", "\n# Used by the simulators", R"(
jobs:
  - id: 1
    name: plate
    min_area_px: 2000
    max_area_px: 200000
    reference: {x_mm: 400.0, y_mm: 0.0, z_mm: 0.0, rz_deg: 0.0}
    limits:
      offset: {rz_deg: [-90, 90]}
      work_area: {x_mm: [250, 450]}
)");
  }));
  ASSERT_NO_FATAL_FAILURE(startRobot("ur5", "ur", kUrPort, {}));
  ASSERT_NO_FATAL_FAILURE(startRobot("irb", "abb", kAbbPort, {}));
  ASSERT_NO_FATAL_FAILURE(startRobot("lrmate", "fanuc", kFanucPort, {}));
  std::this_thread::sleep_for(300ms);
  const auto cycles = plcCycles(10);
  ASSERT_EQ(cycles.size(), 10u);
  const auto got = lines();
  const vgr::sim::CellScenes scenes(cfg_);
  int inside = 0, outside = 0;
  for (const auto& [cycle, plcCode] : cycles) {
    const json entry = journalEntry(cycle);
    ASSERT_TRUE(entry.is_object());
    const auto truth = scenes.truth(entry["frame_id"].get<std::uint64_t>());
    ASSERT_EQ(truth.size(), 1u);
    const double x = truth[0].xMm, rz = truth[0].rzDeg;
    if (std::abs(x - 250) < 1 || std::abs(x - 450) < 1 || std::abs(std::abs(rz) - 90) < 1) continue;  // too close to call
    const bool within = x > 250 && x < 450 && std::abs(rz) < 90;
    (within ? inside : outside)++;
    const int expected = within ? 0 : -9;
    EXPECT_EQ(plcCode, expected) << "PLC ERROR_CODE, cycle " << cycle << " x " << x << " rz " << rz;
    EXPECT_EQ(entry["status"], expected) << entry.dump();
    if (!within) {
      EXPECT_EQ(entry["status_name"], "OFFSET_OUT_OF_LIMITS");
      EXPECT_TRUE(entry["parts"].empty());
      ASSERT_EQ(entry["rejected"].size(), 1u) << entry.dump();
      const std::string why = entry["rejected"][0]["why"];
      EXPECT_TRUE(why.rfind("offset rz ", 0) == 0 || why.rfind("work area x ", 0) == 0) << why;
    }
    // Every robot got this cycle once, with the same status; no pose for -9.
    for (const char* robot : {"ur5", "irb", "lrmate"}) {
      int seen = 0;
      for (const auto& l : got.at(robot))
        if ((l.value("cycle", 0u) & 0xFFFFu) == (cycle & 0xFFFFu)) {
          ++seen;
          EXPECT_EQ(l.value("status", -99), expected) << robot << " " << l.dump();
          if (!within) {
            EXPECT_EQ(l.value("x_mm", 1.0), 0.0) << robot << " " << l.dump();
          }
        }
      EXPECT_EQ(seen, 1) << robot << " cycle " << cycle;
    }
  }
  EXPECT_GT(inside, 0);
  EXPECT_GT(outside, 0);
  std::printf("%d cycles within the limits, %d outside (-9 on the PLC, 3 robots and the journal)\n", inside, outside);
  EXPECT_NE(log("vgrd.log").find("OFFSET_OUT_OF_LIMITS"), std::string::npos);
}

}  // namespace

namespace {

// vgr-sim-robot --program refuses a program that does not fit the cell's robot entry (it
// would play a robot that moves somewhere else): exit 2 naming what disagrees. No sockets.
TEST(robot_program, AProgramThatDisagreesWithTheCellIsRefused) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("vgr-robot-program-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto write = [&](const std::string& robots) {
    std::string y = vgr::config::embeddedSimCellYaml();
    y = replaceSection(y, "\nrobots:\n", "\njobs:\n", "\n" + robots);
    std::ofstream(dir / "cell.yaml") << y;
    return (dir / "cell.yaml").string();
  };
  auto run = [&](const std::string& cfg, const std::string& robot, const std::string& dialect, const std::string& program) {
    return vgr::test::runCommand(vgr::test::binPath("vgr-sim-robot") + " --dialect " + dialect + " --port 1 --name " + robot +
                                 " --config " + cfg + " --program " + vgr::test::sourcePath("examples/robot/" + program) + " 2>&1");
  };
  // The work object of VgrPick.mod is at (400, -200, 0) rz 90: a frame elsewhere is refused.
  auto r = run(write("robots:\n  - {name: irb, dialect: abb, port: 50011, deliver: offset, frame: {name: wConveyor, x_mm: 400, "
                     "y_mm: -150, rz_deg: 90}}\n"),
               "irb", "abb", "VgrPick.mod");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_NE(r.out.find("the program moves in work object wConveyor at (400.000, -200.000, 0.000) mm"), std::string::npos) << r.out;
  // The programs apply offsets: an endpoint delivering poses is refused.
  r = run(write("robots:\n  - {name: ur5, dialect: ur, port: 50010}\n"), "ur5", "ur", "vgr_offset.script");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_NE(r.out.find("must have `deliver: offset`"), std::string::npos) << r.out;
  std::error_code ec;
  fs::remove_all(dir, ec);
}

}  // namespace
