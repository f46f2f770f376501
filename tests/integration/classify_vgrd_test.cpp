// vgrd runs a job with paper 002's classifier in the simulated cell: the classifier is trained
// by the real `vgr classify train` on a labelled set of the sim cell's own plate (its
// renderer's frames, label "plate") and two other classes rendered by `vgr sim render
// --classes disc,square` at the same scale; vgrd then labels every part it locates, and the
// label reaches the journal (parts[].label) and the PLC (LABEL, IR 22).
#include <unistd.h>

#include <modbus.h>

#include <filesystem>
#include <fstream>
#include <sstream>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job.hpp"
#include "sim/scene.hpp"
#include "tests/support/command.hpp"
#include "tests/support/modbus_cell.hpp"

namespace {

using namespace std::chrono_literals;
using vgr::test::ModbusCell;
namespace fs = std::filesystem;

class classify_vgrd : public ModbusCell {
 protected:
  void TearDown() override {
    ModbusCell::TearDown();
    std::error_code ec;
    if (!::testing::Test::HasFailure()) fs::remove_all(dir_, ec);
  }
  fs::path dir_;
};

TEST_F(classify_vgrd, LabelsEveryPartEndToEnd) {
  dir_ = fs::temp_directory_path() / ("vgr-classify-vgrd-" + std::to_string(::getpid()));
  fs::remove_all(dir_);
  fs::create_directories(dir_ / "data");
  auto cfg = vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
  ASSERT_TRUE(cfg.has_value());
  const auto renderer = vgr::sim::SceneRenderer::fromCellConfig(*cfg);

  // Other classes at the sim cell's scale (1280 x 1024, 2 px/mm), then the cell's own plate.
  auto r = vgr::test::runCommand(vgr::test::binPath("vgr") + " sim render --out " + (dir_ / "other").string() +
                                 " --count 12 --seed 3 --classes disc,square --parts 3 --angle-range 180 --noise 2 2>&1");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  std::ofstream csv(dir_ / "data" / "truth.csv");
  csv << "image,x_px,y_px,angle_deg,label\n";
  {
    std::ifstream in(dir_ / "other" / "truth.csv");
    std::string line;
    std::getline(in, line);
    while (std::getline(in, line)) {
      std::vector<std::string> f;
      std::stringstream ss(line);
      for (std::string c; std::getline(ss, c, ',');) f.push_back(c);
      ASSERT_EQ(f.size(), 9u) << line;
      fs::copy_file(dir_ / "other" / f[0], dir_ / "data" / f[0], fs::copy_options::overwrite_existing);
      csv << f[0] << "," << f[1] << "," << f[2] << "," << f[3] << "," << f[8] << "\n";
    }
  }
  cv::Mat img;
  vgr::sim::SceneTruth t0;
  for (int i = 0; i < 30; ++i) {
    const auto t = renderer.render(800000 + i, img);
    if (i == 0) t0 = t;
    const std::string name = fmt::format("plate_{:03d}.png", i);
    ASSERT_TRUE(cv::imwrite((dir_ / "data" / name).string(), img));
    csv << name << "," << t.uPx << "," << t.vPx << "," << t.angleImgDeg << ",plate\n";
  }
  csv.close();

  // The job: method moments on the plate's frame, every blob a part.
  vgr::config::JobFile j;
  j.folder = (dir_ / "job").string();
  fs::create_directories(j.folder);
  j.name = "sorted";
  j.method = "moments";
  j.grasps = {{t0.uPx, t0.vPx}};
  j.taught.grasp = j.grasps.front();
  j.taught.minScore = 0;
  j.taught.maxParts = 16;
  j.taught.params["shape_check"] = "false";  // every blob a candidate: the classifier decides
  renderer.render(800000, img);
  ASSERT_TRUE(cv::imwrite(j.templatePath(), img));
  ASSERT_TRUE(vgr::config::writeJob(j).has_value());
  r = vgr::test::runCommand(vgr::test::binPath("vgr") + " classify train --dataset " + (dir_ / "data").string() + " --out " +
                            j.folder + " 2>&1");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  auto job = vgr::config::loadJob(j.folder);
  ASSERT_TRUE(job.has_value()) << job.error().message;
  ASSERT_EQ(job->classify.model, "classifier.yaml");
  const int plateLabel = 2;  // classes sorted: disc, plate, square

  ASSERT_NO_FATAL_FAILURE(startCell([&](std::string yaml) {
    const auto a = yaml.find("jobs:\n"), b = yaml.find("\n# Used by the simulators");
    yaml.replace(a, b - a, "jobs:\n  - id: 1\n    name: sorted\n    folder: " + j.folder + "\n");
    return yaml;
  }));
  std::vector<std::uint32_t> cycles;
  ASSERT_NO_FATAL_FAILURE(triggerCycles(4, 3000, 5s, cycles));
  for (const auto id : cycles) {
    const nlohmann::json entry = journalEntry(id);
    ASSERT_FALSE(entry.is_null()) << "cycle " << id;
    ASSERT_EQ(entry["status"].get<int>(), 0) << entry.dump();
    ASSERT_EQ(entry["parts"].size(), 1u) << entry.dump();
    EXPECT_EQ(entry["parts"][0]["label"].get<int>(), plateLabel) << entry.dump();
  }
  // The PLC's LABEL register (IR 22) holds the last result's best part's label.
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  std::uint16_t label = 0;
  EXPECT_EQ(modbus_read_input_registers(ctx, 22, 1, &label), 1);
  EXPECT_EQ(label, plateLabel);
  modbus_close(ctx);
  modbus_free(ctx);
}

}  // namespace
