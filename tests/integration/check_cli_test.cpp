// `vgr check` and `vgrd --check` as the operator (and systemd's ExecStartPre) meet them: a
// cell whose job has a misspelt method parameter, or whose calibration file is missing,
// exits 1 naming the file (and line); config file errors keep exit 2. Binds no port.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/cell_config.hpp"
#include "config/job.hpp"
#include "tests/support/command.hpp"

namespace {

namespace fs = std::filesystem;

class check_cli : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           fmt::format("vgr-check-cli-{}-{}", ::testing::UnitTest::GetInstance()->current_test_info()->name(), ::getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "job");
  }
  void TearDown() override { fs::remove_all(dir_); }

  // The example cell (journal in DIR) with a hu job folder DIR/job as job 1, its params
  // `params`; `from` -> `to` applied to the cell config. Returns the config's path.
  std::string cell(const std::string& params, const std::string& from = "", const std::string& to = "") {
    cv::Mat t(150, 200, CV_8UC1, cv::Scalar(20));
    cv::rectangle(t, cv::Rect(40, 30, 120, 80), cv::Scalar(220), cv::FILLED);
    cv::imwrite((dir_ / "job" / "template.png").string(), t);
    vgr::config::JobFile j;
    j.folder = (dir_ / "job").string();
    j.method = "hu";
    j.grasps = {{100, 70}};
    j.taught.grasp = j.grasps.front();
    j.taught.params[params] = "0.2";
    EXPECT_TRUE(vgr::config::writeJob(j).has_value());
    std::string yaml = vgr::config::embeddedSimCellYaml();
    yaml.replace(yaml.find("journal: /tmp/vgr/journal.jsonl"), 31, "journal: " + (dir_ / "journal.jsonl").string());
    yaml.replace(yaml.find("jobs:\n  - id: 1\n"), 16, "jobs:\n  - id: 1\n    folder: job\n  - id: 2\n");
    if (!from.empty()) yaml.replace(yaml.find(from), from.size(), to);
    auto path = vgr::config::writeSimCell(dir_.string(), yaml);
    EXPECT_TRUE(path.has_value());
    return *path;
  }

  // The line of `text` in the job's job.yaml.
  int jobLine(const std::string& text) const {
    std::ifstream in(dir_ / "job" / "job.yaml");
    std::string line;
    for (int n = 1; std::getline(in, line); ++n)
      if (line.find(text) != std::string::npos) return n;
    return 0;
  }

  fs::path dir_;
};

const std::string kBin = VGR_BIN_DIR;

TEST_F(check_cli, AMisspeltJobParameterExits1NamingFileAndLine) {
  const std::string cfg = cell("shape_scal");
  const std::string where = fmt::format("{}:{}", (dir_ / "job" / "job.yaml").string(), jobLine("shape_scal:"));
  for (const std::string& cmd : {kBin + "/vgr check --config " + cfg, kBin + "/vgrd --config " + cfg + " --check"}) {
    const auto r = vgr::test::runCommand(cmd + " 2>&1");
    EXPECT_EQ(r.exitCode, 1) << cmd << "\n" << r.out;
    EXPECT_NE(r.out.find("unknown parameter 'shape_scal'"), std::string::npos) << r.out;
    EXPECT_NE(r.out.find(where), std::string::npos) << where << "\n" << r.out;
  }
}

TEST_F(check_cli, AMissingCalibrationFileExits1NamingTheFile) {
  const std::string cfg = cell("shape_scale", "plane: sim-calib/plane.yaml", "plane: sim-calib/gone.yaml");
  for (const std::string& cmd : {kBin + "/vgr check --config " + cfg, kBin + "/vgrd --config " + cfg + " --check"}) {
    const auto r = vgr::test::runCommand(cmd + " 2>&1");
    EXPECT_EQ(r.exitCode, 1) << cmd << "\n" << r.out;
    EXPECT_NE(r.out.find("sim-calib/gone.yaml"), std::string::npos) << r.out;
  }
}

TEST_F(check_cli, AGoodCellPassesAndAConfigErrorStaysExit2) {
  std::string cfg = cell("shape_scale");
  auto r = vgr::test::runCommand(kBin + "/vgr check --config " + cfg + " 2>&1");
  EXPECT_EQ(r.exitCode, 0) << r.out;
  cfg = cell("shape_scale", "  exposure_us: 5000", "  exposure_usec: 5000");
  r = vgr::test::runCommand(kBin + "/vgr check --config " + cfg + " 2>&1");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_NE(r.out.find("key 'camera.exposure_usec'"), std::string::npos) << r.out;
}

}  // namespace
