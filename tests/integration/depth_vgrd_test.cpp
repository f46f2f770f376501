// vgrd with a depth camera and 3D jobs (issue 14; docs/3d.md "vgrd"), against the depth
// camera emulator over real GVSP, with the example 3D cell (config/examples/sim-cell-3d.yaml,
// written with rendered scenes by tools/vgr/demo3d.hpp):
//  - The emulator reports Scan3dDistanceUnit 'Pixel': the driver refuses the camera at every
//    (re)connect with a line naming the feature; a robot's TRIG is answered -4 CAMERA_ERROR
//    within its deadline, again and again.
//  - A 2D job on a depth camera, and a 3D job on a 2D camera: refused by `vgrd --check`,
//    `vgr check` and vgrd's start (exit 2), with one line naming the job and the camera.
//    (Before this change the first started and answered -2 on every cycle.)
//  - A scene without a part answers 1 NO_PART_FOUND, a half-hidden part 4 RETRY_NEW_VIEWPOINT,
//    to the PLC (ERROR_CODE, the ERROR bit off) and to a robot, both journalled; vgrd serves on.
#include <chrono>
#include <filesystem>
#include <fstream>
#include <map>
#include <sstream>
#include <string>
#include <thread>
#include <vector>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/command.hpp"
#include "tests/support/raw_tcp_client.hpp"
#include "tests/support/sim_cell.hpp"
#include "tools/vgr/demo3d.hpp"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;

// "(status,cycle,...)" -> status.
int urStatus(const std::string& reply) {
  if (reply.size() < 3 || reply.front() != '(') return -99;
  return std::stoi(reply.substr(1, reply.find(',') - 1));
}

std::string readText(const fs::path& p) {
  std::ifstream in(p);
  return std::string((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
}

class depth_vgrd : public vgr::test::SimCell {
 protected:
  // The example 3D cell with `scenes` rendered scenes in dir_ (config, hand-eye, 3D job).
  void prepare3dCell(int scenes, const vgr::tools::Demo3dScenes& choice = {}) {
    for (const int port : {kModbusPort, kUrPort, kAbbPort, kFanucPort})
      ASSERT_TRUE(portFree(port)) << "127.0.0.1:" << port << " is taken: another cell is running on this machine";
    dir_ = fs::temp_directory_path() / ("vgr-cell3d-" + std::to_string(::getpid()) + "-" + std::to_string(counter_++));
    fs::create_directories(dir_);
    auto config = vgr::tools::prepareDemo3d(dir_.string(), scenes, 3, choice);
    ASSERT_TRUE(config) << config.error().message;
    configPath_ = *config;
    auto cfg = vgr::config::loadCellConfig(configPath_);
    ASSERT_TRUE(cfg) << cfg.error().message;
    cfg_ = *cfg;
  }
  // The depth emulator on dir_/scenes, in `unit`; then vgrd, waited for until READY=1 when
  // `waitReady` (the 3D job's model features are computed at start: up to a minute loaded).
  void start3dCell(const std::string& unit, bool waitReady) {
    camera_ = vgr::test::startEmulator({"--config", configPath_, "--depth", (dir_ / "scenes").string(), "--depth-unit", unit,
                                        "--truth", (dir_ / "truth.jsonl").string()},
                                       (dir_ / "camera.log").string(), std::chrono::milliseconds(15000));
    ASSERT_NE(camera_, nullptr);
    notify_ = std::make_unique<vgr::test::NotifySocket>((dir_ / "notify.sock").string());
    auto p = vgr::test::spawnWithNotify({bin("vgrd"), "--config", configPath_, "--journal", journalPath()},
                                        (dir_ / "vgrd.log").string(), *notify_);
    ASSERT_TRUE(p.has_value());
    vgrd_ = std::make_unique<vgr::test::ChildProcess>(std::move(*p));
    if (waitReady) ASSERT_TRUE(waitNotify("READY=1", std::chrono::milliseconds(90000))) << log("vgrd.log");
  }
  static inline int counter_ = 0;
};

TEST_F(depth_vgrd, a_camera_in_an_unknown_unit_is_refused_and_vgrd_answers_camera_error) {
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(1));
  ASSERT_NO_FATAL_FAILURE(start3dCell("Pixel", false));
  // The robot port comes up while the camera is being refused (after the 3D job is built).
  std::unique_ptr<vgr::test::RawTcpClient> ur;
  for (int i = 0; i < 900 && !ur; ++i) {
    vgr::test::RawTcpClient::Options o;
    o.throwOnFailure = false;
    auto c = std::make_unique<vgr::test::RawTcpClient>(kUrPort, o);
    if (c->connected()) ur = std::move(c);
    else std::this_thread::sleep_for(100ms);
  }
  ASSERT_TRUE(ur) << log("vgrd.log");
  for (int i = 0; i < 2; ++i) {
    ASSERT_TRUE(ur->send("TRIG,1\n"));
    const auto reply = ur->readUntil(')', 30000ms);
    ASSERT_TRUE(reply) << log("vgrd.log");
    EXPECT_EQ(urStatus(*reply), -4) << *reply;
  }
  EXPECT_TRUE(vgrd_->running());
  // The camera worker logs why it refuses the camera when its connect attempt ends, which
  // may be after the two cycles above were answered: wait for the line (up to 10 s).
  std::string l = log("vgrd.log");
  for (int i = 0; i < 100 && l.find("Scan3dDistanceUnit is 'Pixel'") == std::string::npos; ++i) {
    std::this_thread::sleep_for(100ms);
    l = log("vgrd.log");
  }
  EXPECT_NE(l.find("Scan3dDistanceUnit is 'Pixel'"), std::string::npos) << l;
}

TEST_F(depth_vgrd, a_2d_job_on_a_depth_camera_is_refused_at_check_and_start) {
  ASSERT_NO_FATAL_FAILURE(prepareCell([](std::string yaml) { return yaml; }));
  // The 2D example with its camera made a depth camera (and no calibration: a depth camera
  // takes the hand-eye alone).
  std::string yaml = readText(configPath_);
  const auto at = yaml.find("pixel_format: Mono8");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 19, "pixel_format: Coord3D_C16");
  const auto cal = yaml.find("\ncalibration:\n"), modbus = yaml.find("\nmodbus:\n");
  ASSERT_TRUE(cal != std::string::npos && modbus != std::string::npos);
  yaml.erase(cal, modbus - cal);
  std::ofstream(configPath_) << yaml;
  const std::string line = "job 1 is a 2D job (method moments) and camera 'cam0' is a depth camera";
  const auto check = vgr::test::runCommand(bin("vgrd") + " --check --config " + configPath_ + " 2>&1");
  EXPECT_EQ(check.exitCode, 2) << check.out;
  EXPECT_NE(check.out.find(line), std::string::npos) << check.out;
  const auto vgrCheck = vgr::test::runVgr("check --config " + configPath_);
  EXPECT_EQ(vgrCheck.exitCode, 2) << vgrCheck.out;
  EXPECT_NE(vgrCheck.out.find(line), std::string::npos) << vgrCheck.out;
  const auto start = vgr::test::runCommand(bin("vgrd") + " --config " + configPath_ + " --journal " + journalPath() + " 2>&1",
                                           std::chrono::milliseconds(30000));
  EXPECT_EQ(start.exitCode, 2) << start.out;
  EXPECT_NE(start.out.find(line), std::string::npos) << start.out;
}

TEST_F(depth_vgrd, a_3d_job_on_a_2d_camera_is_refused_at_check_and_start) {
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(1));
  std::string yaml = readText(configPath_);
  const auto at = yaml.find("pixel_format: Coord3D_C16");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 25, "pixel_format: Mono8");
  std::ofstream(configPath_) << yaml;
  const std::string line = "job 1 is a 3D job (kind: 3d) and camera 'depth0' is a 2D camera (pixel_format Mono8)";
  const auto vgrCheck = vgr::test::runVgr("check --config " + configPath_);
  EXPECT_EQ(vgrCheck.exitCode, 2) << vgrCheck.out;
  EXPECT_NE(vgrCheck.out.find(line), std::string::npos) << vgrCheck.out;
  const auto start = vgr::test::runCommand(bin("vgrd") + " --config " + configPath_ + " --journal " + journalPath() + " 2>&1",
                                           std::chrono::milliseconds(30000));
  EXPECT_EQ(start.exitCode, 2) << start.out;
  EXPECT_NE(start.out.find(line), std::string::npos) << start.out;
}

}  // namespace

namespace {

// A scene without a part and a half-hidden part: 1 NO_PART_FOUND and 4 RETRY_NEW_VIEWPOINT on
// the PLC (ERROR_CODE; the result is valid, PART_FOUND off) and to a robot, journalled, vgrd
// serving on. Which scene is empty comes from the emulator's truth per frame.
TEST_F(depth_vgrd, no_part_is_not_found_and_a_half_hidden_part_asks_for_a_new_viewpoint) {
  vgr::tools::Demo3dScenes scenes;
  scenes.emptyRatio = 0.5;
  scenes.occlusion = 0.55;
  ASSERT_NO_FATAL_FAILURE(prepare3dCell(2, scenes));
  ASSERT_NO_FATAL_FAILURE(start3dCell("Millimeter", true));
  auto plc = vgr::test::runCommand(bin("vgr-sim-plc") + " --host 127.0.0.1 --port 1502 --cycles 2 --job 1 --timeout-ms 40000 --json",
                                   std::chrono::milliseconds(120000));
  ASSERT_EQ(plc.exitCode, 0) << plc.out << log("vgrd.log");
  std::map<std::uint64_t, bool> hasPart;  // by frame id, from the emulator's truth
  {
    std::ifstream in(dir_ / "truth.jsonl");
    for (std::string line; std::getline(in, line);) {
      const auto j = nlohmann::json::parse(line, nullptr, false);
      if (!j.is_discarded()) hasPart[j["frame_id"].get<std::uint64_t>()] = !j["parts"].empty();
    }
  }
  std::istringstream lines(plc.out);
  int seen = 0, retries = 0, notFound = 0;
  for (std::string line; std::getline(lines, line);) {
    const auto p = nlohmann::json::parse(line, nullptr, false);
    if (p.is_discarded() || !p.contains("n")) continue;
    ++seen;
    const int status = p["status"].get<int>();
    const auto j = journalEntry(p["result_id"].get<std::uint32_t>());
    ASSERT_FALSE(j.is_null()) << line;
    EXPECT_EQ(j["status"].get<int>(), status) << line;
    const auto frame = j["frame_id"].get<std::uint64_t>();
    ASSERT_TRUE(hasPart.count(frame)) << "frame " << frame << " not in the emulator's truth";
    if (!hasPart[frame]) {
      EXPECT_EQ(status, 1) << "no part in frame " << frame << ": " << line;
      notFound += status == 1;
    } else {
      EXPECT_EQ(status, 4) << "a half-hidden part in frame " << frame << ": " << line;
      retries += status == 4;
    }
    EXPECT_EQ(p["num_found"].get<int>(), 0) << line;
  }
  EXPECT_EQ(seen, 2) << plc.out;
  EXPECT_EQ(notFound + retries, 2) << plc.out;
  // The robot gets the last result's status, with no pose; the connection stays.
  vgr::test::RawTcpClient ur(kUrPort);
  ASSERT_TRUE(ur.send("GET,1\n"));
  const auto reply = ur.readUntil(')', 5000ms);
  ASSERT_TRUE(reply);
  const int last = journal().back()["status"].get<int>();
  EXPECT_EQ(urStatus(*reply), last) << *reply;
  EXPECT_NE(reply->find(",0.000000,0.000000,0.000000"), std::string::npos) << *reply;
  EXPECT_TRUE(vgrd_->running());
}

}  // namespace
