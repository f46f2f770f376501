// vgrd runs a taught job (a job folder written like `vgr teach` writes it) in the simulated
// cell: the camera emulator serves rendered frames, a libmodbus PLC triggers in counter mode,
// and every cycle's pose (journal) is checked against the renderer's ground truth. A broken
// job.yaml fails `vgrd --check` naming file, line and key; a method that cannot be built
// from the job fails vgrd's start naming the job folder.
#include <unistd.h>

#include <modbus.h>

#include <cmath>
#include <fstream>
#include <thread>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job.hpp"
#include "sim/scene.hpp"
#include "tests/support/modbus_cell.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;

class locate_vgrd_job : public ModbusCell {
 protected:
  // Teaches a job on frame `frame` of the sim cell's renderer: the template is the whole
  // frame, the grasp point the part's centroid (its truth). Returns the job folder.
  std::string teach(const std::string& method, const std::map<std::string, std::string>& params,
                    vgr::sim::SceneTruth& truth0) {
    auto cfg = vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
    EXPECT_TRUE(cfg.has_value());
    const auto renderer = vgr::sim::SceneRenderer::fromCellConfig(*cfg);
    cv::Mat templ;
    truth0 = renderer.render(900000, templ);
    jobDir_ = std::filesystem::temp_directory_path() / ("vgr-locate-job-" + std::to_string(::getpid()));
    std::filesystem::remove_all(jobDir_);
    std::filesystem::create_directories(jobDir_);
    vgr::config::JobFile j;
    j.folder = jobDir_.string();
    j.name = "plate";
    j.method = method;
    j.grasps = {{truth0.uPx, truth0.vPx}};
    j.taught.grasp = j.grasps.front();
    j.taught.params = params;
    j.referenceXMm = 400;
    EXPECT_TRUE(cv::imwrite(j.templatePath(), templ));
    EXPECT_TRUE(vgr::config::writeJob(j).has_value());
    return j.folder;
  }

  // The sim cell's job 1 replaced by one naming a folder.
  static std::string withFolderJob(std::string yaml, const std::string& folder, double angleOffsetDeg) {
    const auto a = yaml.find("jobs:\n"), b = yaml.find("\n# Used by the simulators");
    yaml.replace(a, b - a, "jobs:\n  - id: 1\n    name: plate\n    folder: " + folder +
                               "\n    angle_offset_deg: " + std::to_string(angleOffsetDeg) + "\n");
    return yaml;
  }

  void TearDown() override {
    ModbusCell::TearDown();
    std::error_code ec;
    if (!::testing::Test::HasFailure()) std::filesystem::remove_all(jobDir_, ec);
  }

  std::filesystem::path jobDir_;
};

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

TEST_F(locate_vgrd_job, RunsATaughtHuJobAndDeliversTruePoses) {
  vgr::sim::SceneTruth t0;
  const std::string folder = teach("hu", {}, t0);
  // The taught method reports the rotation from the template; the template's own axis is at
  // t0.angleImgDeg in the image, which is what angle_offset_deg says (docs/localization.md).
  ASSERT_NO_FATAL_FAILURE(startCell([&](std::string y) { return withFolderJob(y, folder, t0.angleImgDeg); }));
  EXPECT_NE(log("vgrd.log").find("method hu from"), std::string::npos) << log("vgrd.log");

  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  std::vector<std::uint32_t> cycles;
  for (int n = 0; n < 4; ++n) {
    const auto r = triggerCounter(ctx, static_cast<std::uint16_t>(1000 + n), 5s);
    ASSERT_TRUE(r.status & 0x08) << "RESULT_VALID";
    EXPECT_EQ(r.error, 0) << "ERROR_CODE";
    cycles.push_back(r.resultId);
    std::this_thread::sleep_for(20ms);
  }
  modbus_close(ctx);
  modbus_free(ctx);

  const auto renderer = vgr::sim::SceneRenderer::fromCellConfig(cfg_);
  for (const auto id : cycles) {
    const nlohmann::json entry = journalEntry(id);
    ASSERT_FALSE(entry.is_null()) << "cycle " << id;
    ASSERT_EQ(entry["status"].get<int>(), 0) << entry.dump();
    ASSERT_EQ(entry["parts"].size(), 1u) << entry.dump();
    const auto& p = entry["parts"][0];
    const auto truth = renderer.truthForFrame(entry["frame_id"].get<std::uint64_t>());
    // hu's centroid is within 0.3 px (locate_methods_test) = 0.15 mm at 2 px/mm.
    EXPECT_LT(std::hypot(p["x_mm"].get<double>() - truth.xMm, p["y_mm"].get<double>() - truth.yMm), 0.5) << entry.dump();
    EXPECT_LT(angleDiff(p["rz_deg"].get<double>(), truth.rzDeg), 0.5) << entry.dump();
    EXPECT_NEAR(p["u_px"].get<double>(), truth.uPx, 1.0);
  }
}

TEST_F(locate_vgrd_job, BrokenJobYamlFailsTheCheckNamingFileLineAndKey) {
  vgr::sim::SceneTruth t0;
  const std::string folder = teach("hu", {}, t0);
  {
    std::ofstream(jobDir_ / "job.yaml", std::ios::app) << "max_partz: 3\n";
  }
  dir_ = jobDir_;
  const std::string cfgPath = (jobDir_ / "cell.yaml").string();
  std::ofstream(cfgPath) << withFolderJob(vgr::config::embeddedSimCellYaml(), folder, 0);
  auto p = vgr::test::ChildProcess::spawn({bin("vgrd"), "--config", cfgPath, "--check"}, (jobDir_ / "check.log").string());
  ASSERT_TRUE(p.has_value());
  const int rc = p->wait(std::chrono::milliseconds(10000));
  const std::string out = log("check.log");
  EXPECT_EQ(rc, 2) << out;
  EXPECT_NE(out.find(folder + "/job.yaml:"), std::string::npos) << out;
  EXPECT_NE(out.find("key 'max_partz': unknown key"), std::string::npos) << out;
}

TEST_F(locate_vgrd_job, AMethodThatCannotBeBuiltStopsTheStartNamingTheJob) {
  vgr::sim::SceneTruth t0;
  const std::string folder = teach("hu", {{"shape_scale", "-1"}}, t0);
  dir_ = jobDir_;
  const std::string cfgPath = (jobDir_ / "cell.yaml").string();
  std::string yaml = withFolderJob(vgr::config::embeddedSimCellYaml(), folder, 0);
  yaml.replace(yaml.find("journal: /tmp/vgr/journal.jsonl"), 31, "journal: " + (jobDir_ / "j.jsonl").string());
  std::ofstream(cfgPath) << yaml;
  auto p = vgr::test::ChildProcess::spawn({bin("vgrd"), "--config", cfgPath}, (jobDir_ / "start.log").string());
  ASSERT_TRUE(p.has_value());
  const int rc = p->wait(std::chrono::milliseconds(10000));
  const std::string out = log("start.log");
  EXPECT_EQ(rc, 1) << out;
  EXPECT_NE(out.find("job 1 (" + folder + "): hu: parameter 'shape_scale'"), std::string::npos) << out;
}

}  // namespace
