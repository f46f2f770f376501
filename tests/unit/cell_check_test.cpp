// `vgr check` / `vgrd --check` (daemon/check.hpp): everything vgrd would load is loaded and
// validated. Config file errors (YAML, keys, ranges) exit 2; a config that parses but names
// something vgrd cannot use (a job whose method cannot be built, a missing calibration file,
// an unwritable journal, a bind host that does not resolve) exits 1, naming the file.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>
#include <utility>
#include <vector>

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/cell_config.hpp"
#include "config/job.hpp"
#include "daemon/check.hpp"

namespace {

namespace fs = std::filesystem;

class cell_check : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / fmt::format("vgr-cell-check-{}-{}", ::testing::UnitTest::GetInstance()->current_test_info()->name(), ::getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_);
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The example cell with `from` replaced by `to`, written as DIR/sim-cell.yaml (with the
  // example's calibration files); the check's answer.
  vgr::daemon::CheckResult check(const std::string& from = "", const std::string& to = "") {
    if (from.empty()) return check(std::vector<std::pair<std::string, std::string>>{});
    return check(std::vector<std::pair<std::string, std::string>>{{from, to}});
  }
  vgr::daemon::CheckResult check(const std::vector<std::pair<std::string, std::string>>& edits) {
    std::string yaml = vgr::config::embeddedSimCellYaml();
    yaml.replace(yaml.find("journal: /tmp/vgr/journal.jsonl"), 31, "journal: " + (dir_ / "journal.jsonl").string());
    for (const auto& [from, to] : edits) {
      const auto at = yaml.find(from);
      EXPECT_NE(at, std::string::npos) << from;
      if (at != std::string::npos) yaml.replace(at, from.size(), to);
    }
    auto path = vgr::config::writeSimCell(dir_.string(), yaml);
    EXPECT_TRUE(path.has_value());
    return vgr::daemon::checkCellConfig(*path);
  }

  // A hu job folder DIR/job with a bright rectangle template and `params`.
  std::string job(const std::map<std::string, std::string>& params) {
    const fs::path folder = dir_ / "job";
    fs::create_directories(folder);
    cv::Mat t(150, 200, CV_8UC1, cv::Scalar(20));
    cv::rectangle(t, cv::Rect(40, 30, 120, 80), cv::Scalar(220), cv::FILLED);
    cv::imwrite((folder / "template.png").string(), t);
    vgr::config::JobFile j;
    j.folder = folder.string();
    j.method = "hu";
    j.grasps = {{100, 70}};
    j.taught.grasp = j.grasps.front();
    j.taught.params = params;
    EXPECT_TRUE(vgr::config::writeJob(j).has_value());
    return folder.string();
  }
  std::string withJobFolder(const std::string& folder) const {
    return "jobs:\n  - id: 1\n    folder: " + folder + "\n  - id: 2\n";
  }

  fs::path dir_;
};

TEST_F(cell_check, TheExampleCellPasses) {
  const auto r = check();
  ASSERT_TRUE(r.has_value()) << r.error().message;
}

TEST_F(cell_check, AJobWithAMisspeltParameterExits1NamingFileAndLine) {
  const std::string folder = job({{"shape_scal", "0.2"}});
  const auto r = check("jobs:\n  - id: 1\n", withJobFolder(folder));
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find("unknown parameter 'shape_scal'"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(folder + "/job.yaml:"), std::string::npos) << r.error().message;
}

TEST_F(cell_check, AGoodJobFolderPasses) {
  const auto r = check("jobs:\n  - id: 1\n", withJobFolder(job({{"shape_scale", "0.2"}})));
  ASSERT_TRUE(r.has_value()) << r.error().message;
}

TEST_F(cell_check, AMissingCalibrationFileExits1NamingTheFile) {
  const auto r = check("plane: sim-calib/plane.yaml", "plane: sim-calib/no-plane.yaml");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find("sim-calib/no-plane.yaml"), std::string::npos) << r.error().message;
}

TEST_F(cell_check, AnUnwritableJournalExits1) {
  std::ofstream(dir_ / "a-file") << "x";
  const auto r = check("journal: " + (dir_ / "journal.jsonl").string(), "journal: " + (dir_ / "a-file" / "journal.jsonl").string());
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find("journal " + (dir_ / "a-file" / "journal.jsonl").string()), std::string::npos) << r.error().message;
}

TEST_F(cell_check, ARobotBindHostThatDoesNotResolveExits1) {
  const auto r = check("    dialect: abb\n    bind: 127.0.0.1", "    dialect: abb\n    bind: no-such-host.invalid");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find("robots[1].bind"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("no-such-host.invalid"), std::string::npos) << r.error().message;
}

TEST_F(cell_check, ModbusBindLocalhostIsRefusedWithAHint) {
  const auto r = check("  bind: 127.0.0.1\n  port: 1502", "  bind: localhost\n  port: 1502");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 2) << r.error().message;
  EXPECT_NE(r.error().message.find("key 'modbus.bind'"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("127.0.0.1"), std::string::npos) << r.error().message;
}

TEST_F(cell_check, ADuplicateKeyIsAnError) {
  const auto r = check("  exposure_us: 5000\n", "  exposure_us: 5000\n  exposure_us: 900\n");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 2) << r.error().message;
  EXPECT_NE(r.error().message.find("key 'camera.exposure_us': duplicate key"), std::string::npos) << r.error().message;
}

TEST_F(cell_check, ADeadlineInsideTheProcessingReserveIsRefused) {
  const auto r = check("cycle_deadline_ms: 1500", "cycle_deadline_ms: 150");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 2) << r.error().message;
  EXPECT_NE(r.error().message.find("key 'cell.cycle_deadline_ms'"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("150 ms"), std::string::npos) << r.error().message;
}

// What vgrd's start opens besides the journal (daemon/vgrd_app.cpp, daemon/plant.cpp): the
// image archive's folder, the MQTT sink's TLS files, a replay camera's folder. Each of these
// passed the check before and then stopped vgrd's start (exit 1) or, for the replay camera,
// made every cycle answer -4.
TEST_F(cell_check, AnArchiveFolderThatCannotBeCreatedExits1) {
  std::ofstream(dir_ / "a-file") << "x";
  const std::string archive = (dir_ / "a-file" / "archive").string();
  const auto r = check("modbus:\n", "archive: {dir: " + archive + "}\nmodbus:\n");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find("key 'archive.dir'"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(archive), std::string::npos) << r.error().message;
  EXPECT_FALSE(fs::exists(dir_ / "archive"));  // nothing created, neither here nor next to the journal
}

TEST_F(cell_check, TheDefaultArchiveFolderIsCheckedNextToTheJournal) {
  fs::create_directories(dir_ / "logs");
  std::ofstream(dir_ / "logs" / "archive") << "x";  // a file where vgrd would create its folder
  const auto r = check({{"journal: " + (dir_ / "journal.jsonl").string(), "journal: " + (dir_ / "logs" / "journal.jsonl").string()},
                        {"modbus:\n", "archive: {every_nth_good: 0}\nmodbus:\n"}});
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find((dir_ / "logs" / "archive").string()), std::string::npos) << r.error().message;
}

TEST_F(cell_check, AMissingMqttTlsFileExits1) {
  const std::string ca = (dir_ / "no-ca.pem").string();
  const auto r = check("modbus:\n", "mqtt: {host: 127.0.0.1, tls: {ca_file: " + ca + "}}\nmodbus:\n");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find("key 'mqtt.tls'"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(ca), std::string::npos) << r.error().message;
}

TEST_F(cell_check, AReplayCameraWithoutImagesExits1) {
  fs::create_directories(dir_ / "frames");
  const std::string folder = (dir_ / "frames").string();
  const auto r = check("  driver: aravis\n", "  driver: replay\n  replay: {folder: " + folder + "}\n");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find("camera.replay.folder"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find(folder), std::string::npos) << r.error().message;
}

// The camera's ROI fixes the frame size; a calibration made for another size makes every
// cycle answer -6 NOT_CALIBRATED (daemon/cycle_runner.cpp), so the check refuses it.
TEST_F(cell_check, ACameraRoiOfAnotherSizeThanTheCalibrationExits1) {
  auto r = check("  pixel_format: Mono8\n", "  pixel_format: Mono8\n  roi: {width: 640, height: 512}\n");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 1) << r.error().message;
  EXPECT_NE(r.error().message.find("key 'camera.roi'"), std::string::npos) << r.error().message;
  EXPECT_NE(r.error().message.find("1280x1024"), std::string::npos) << r.error().message;
  r = check("  pixel_format: Mono8\n", "  pixel_format: Mono8\n  roi: {width: 1280, height: 1024}\n");
  EXPECT_TRUE(r.has_value()) << r.error().message;
}

// vgrd's start binds the web port after the robots' and Modbus ports: the same port twice
// stopped the start (exit 1) after passing the check.
TEST_F(cell_check, AWebPortUsedByAnotherEndpointIsRefused) {
  const auto r = check("modbus:\n", "web: {port: 50011}\nmodbus:\n");
  ASSERT_FALSE(r.has_value());
  EXPECT_EQ(r.error().exitCode, 2) << r.error().message;
  EXPECT_NE(r.error().message.find("key 'web.port': port already used by another endpoint"), std::string::npos)
      << r.error().message;
  EXPECT_TRUE(check("modbus:\n", "web: {port: 8080}\nmodbus:\n").has_value());
}

TEST_F(cell_check, ACellCalibratedWithFilesNeedsNoModel) {
  std::string yaml = vgr::config::embeddedSimCellYaml();
  const auto a = yaml.find("model:\n"), b = yaml.find("calibration:\n");
  ASSERT_NE(a, std::string::npos);
  ASSERT_NE(b, std::string::npos);
  yaml.erase(a, b - a);
  auto cfg = vgr::config::parseCellConfig(yaml, (dir_ / "cell.yaml").string());
  ASSERT_TRUE(cfg.has_value()) << cfg.error().message;
  yaml.erase(yaml.find("calibration:\n"), yaml.find("modbus:\n") - yaml.find("calibration:\n"));
  cfg = vgr::config::parseCellConfig(yaml, (dir_ / "cell.yaml").string());
  ASSERT_FALSE(cfg.has_value());
  EXPECT_NE(cfg.error().message.find("key 'model': required"), std::string::npos) << cfg.error().message;
}

}  // namespace

namespace {

TEST(cell_check_text, NonUtf8BytesAreAnErrorNamingTheLine) {
  std::string yaml = vgr::config::embeddedSimCellYaml();
  const auto at = yaml.find("  name: sim-cell");
  ASSERT_NE(at, std::string::npos);
  yaml.replace(at, 16, "  name: sim-c\xe9ll");  // Latin-1 e-acute
  const int line = 1 + static_cast<int>(std::count(yaml.begin(), yaml.begin() + static_cast<long>(at), '\n'));
  auto cfg = vgr::config::parseCellConfig(yaml, "CELL.yaml");
  ASSERT_FALSE(cfg.has_value()) << "a Latin-1 byte was read as " << cfg->name;
  EXPECT_NE(cfg.error().message.find(fmt::format("CELL.yaml:{}: ", line)), std::string::npos) << cfg.error().message;
  EXPECT_NE(cfg.error().message.find("UTF-8"), std::string::npos) << cfg.error().message;

  vgr::config::JobFile j;
  j.folder = "JOB";
  j.name = "caf\xe9";
  j.grasps = {{1, 1}};
  std::string text = vgr::config::jobYaml(j);
  auto job = vgr::config::parseJob(text, "JOB/job.yaml", "JOB");
  ASSERT_FALSE(job.has_value());
  EXPECT_NE(job.error().message.find("UTF-8"), std::string::npos) << job.error().message;
}

}  // namespace
