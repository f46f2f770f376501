// Job folders (config/job.hpp): round trip through job.yaml, and broken jobs reported with
// file, line and key. `vgr eval` (tools/vgr/eval_report.hpp) on a small rendered dataset.
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <algorithm>

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "config/job.hpp"
#include "tools/vgr/eval_report.hpp"
#include "sim/dataset.hpp"

namespace {

namespace fs = std::filesystem;

fs::path tempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / fmt::format("vgr-locate-{}-{}", name, ::getpid());
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

vgr::config::JobFile sampleJob(const fs::path& dir) {
  vgr::config::JobFile j;
  j.folder = dir.string();
  j.name = "bracket";
  j.method = "hu";
  j.grasps = {{120.5, 80.25}, {10, 20}};
  j.taught.grasp = j.grasps.front();
  j.taught.searchRoi = {10, 20, 300, 200};
  j.taught.minScore = 0.6;
  j.taught.maxParts = 3;
  j.taught.angleMinDeg = -60;
  j.taught.angleMaxDeg = 60;
  j.taught.params["shape_scale"] = "0.2";
  j.taught.regions.push_back({{{0, 0}, {10, 0}, {10, 10}}, 20, 0.1});
  j.partHeightMm = 35;
  j.referenceXMm = 400;
  j.referenceRzDeg = 90;
  return j;
}

TEST(locate_job, RoundTripsThroughJobYaml) {
  const fs::path dir = tempDir("roundtrip");
  const auto j = sampleJob(dir);
  ASSERT_TRUE(vgr::config::writeJob(j).has_value());
  auto back = vgr::config::loadJob(dir.string());
  ASSERT_TRUE(back.has_value()) << back.error().message;
  EXPECT_EQ(back->name, "bracket");
  EXPECT_EQ(back->method, "hu");
  ASSERT_EQ(back->grasps.size(), 2u);
  EXPECT_DOUBLE_EQ(back->taught.grasp.u, 120.5);
  EXPECT_DOUBLE_EQ(back->taught.grasp.v, 80.25);
  EXPECT_EQ(back->taught.searchRoi.width, 300);
  EXPECT_DOUBLE_EQ(back->taught.minScore, 0.6);
  EXPECT_EQ(back->taught.maxParts, 3);
  EXPECT_DOUBLE_EQ(back->taught.angleMinDeg, -60);
  EXPECT_EQ(back->taught.params.at("shape_scale"), "0.2");
  ASSERT_EQ(back->taught.regions.size(), 1u);
  EXPECT_DOUBLE_EQ(back->taught.regions[0].heightFactor, 0.1);
  EXPECT_DOUBLE_EQ(back->taught.regions[0].heightMm, 20);
  EXPECT_DOUBLE_EQ(back->partHeightMm, 35);
  EXPECT_DOUBLE_EQ(back->referenceRzDeg, 90);
  EXPECT_EQ(back->templatePath(), (dir / "template.png").string());
  fs::remove_all(dir);
}

// Replaces `from` by `to` in the written job.yaml and returns the load error.
std::string brokenJob(const std::string& from, const std::string& to) {
  const fs::path dir = tempDir("broken");
  const std::string yaml = vgr::config::jobYaml(sampleJob(dir));
  const auto at = yaml.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  std::string bad = yaml;
  bad.replace(at, from.size(), to);
  auto r = vgr::config::parseJob(bad, "JOB/job.yaml", dir.string());
  fs::remove_all(dir);
  return r ? std::string("loaded") : r.error().message;
}

int lineOf(const std::string& yaml, const std::string& text) {
  const auto at = yaml.find(text);
  return 1 + static_cast<int>(std::count(yaml.begin(), yaml.begin() + static_cast<long>(at), '\n'));
}

TEST(locate_job, BrokenJobsNameFileLineAndKey) {
  const std::string yaml = vgr::config::jobYaml(sampleJob("x"));
  EXPECT_EQ(brokenJob("height_factor: 0.1", "height_factor: 2"),
            fmt::format("JOB/job.yaml:{}: key 'regions[0].height_factor': expected a number in [0, 1], got '2'",
                        lineOf(yaml, "height_factor")));
  EXPECT_EQ(brokenJob("max_parts: 3", "max_part: 3"), fmt::format("JOB/job.yaml:{}: key 'max_part': unknown key", lineOf(yaml, "max_parts")));
  EXPECT_NE(brokenJob("{x_px: 120.5, y_px: 80.25}", "{x_px: abc, y_px: 80.25}").find("key 'grasps[0].x_px': expected a number"),
            std::string::npos);
  EXPECT_NE(brokenJob("polygon: [[0, 0], [10, 0], [10, 10]]", "polygon: [[0, 0], [10, 0]]").find("key 'regions[0].polygon'"),
            std::string::npos);
  EXPECT_NE(brokenJob("angle_min_deg: -60", "angle_min_deg: 70").find("key 'angle_max_deg': must not be below angle_min_deg"),
            std::string::npos);
  auto missing = vgr::config::loadJob("/nonexistent/job");
  ASSERT_FALSE(missing.has_value());
  EXPECT_EQ(missing.error().message, "/nonexistent/job/job.yaml: cannot open the job file");
}

TEST(locate_job, EvalScoresAMethodAgainstTheDatasetTruth) {
  const fs::path dir = tempDir("eval");
  vgr::sim::DatasetOptions d;
  d.outDir = (dir / "data").string();
  d.count = 6;
  d.part = "flat";
  d.scene.width = 640;
  d.scene.height = 512;
  d.scene.focalPx = 1000;
  d.scene.partsPerImage = 2;
  d.scene.emptyRatio = 0.4;
  d.scene.seed = 2;
  d.scene.noiseSigma = 2;
  d.scene.angleRangeDeg = 180;
  auto sum = vgr::sim::writeDataset(d);
  ASSERT_TRUE(sum.has_value()) << sum.error().message;
  ASSERT_GT(sum->emptyImages, 0);

  // A job on the dataset's template, as `vgr teach` writes it.
  vgr::config::JobFile j;
  j.folder = (dir / "job").string();
  fs::create_directories(j.folder);
  j.method = "moments";
  fs::copy_file(dir / "data" / "template.png", fs::path(j.folder) / "template.png");
  auto regions = vgr::config::loadRegions((dir / "data" / "template.yaml").string());
  ASSERT_TRUE(regions.has_value()) << regions.error().message;
  j.taught.regions = *regions;
  j.taught.maxParts = 4;
  std::ifstream ty(dir / "data" / "template.yaml");
  std::string line;
  while (std::getline(ty, line))
    if (line.rfind("grasp:", 0) == 0) std::sscanf(line.c_str(), "grasp: {x_px: %lf, y_px: %lf}", &j.taught.grasp.u, &j.taught.grasp.v);
  j.grasps = {j.taught.grasp};
  ASSERT_TRUE(vgr::config::writeJob(j).has_value());

  vgr::tools::EvalOptions o;
  o.jobFolder = j.folder;
  o.datasetFolder = d.outDir;
  auto rep = vgr::tools::evaluate(o);
  ASSERT_TRUE(rep.has_value()) << rep.error().message;
  EXPECT_EQ(rep->images, 6);
  EXPECT_EQ(rep->n, sum->parts + sum->emptyImages);
  EXPECT_EQ(rep->parts, sum->parts);
  EXPECT_EQ(rep->missed, 0);
  EXPECT_EQ(rep->falsePositives, 0);
  // The flat part with moments: the centroid is exact to ~0.1 px (moments_locator_test).
  EXPECT_DOUBLE_EQ(rep->successRate(), 1.0);
  const auto js = nlohmann::json::parse(vgr::tools::evalJson(*rep, o));
  for (const char* k : {"n", "success_rate", "pos_err_px_mean", "pos_err_px_max", "ang_err_deg_mean", "ang_err_deg_max", "time_ms_median"})
    EXPECT_TRUE(js.contains(k)) << k;
  EXPECT_LT(js["pos_err_px_max"].get<double>(), 0.5);

  // A stricter tolerance than the errors fails every part but keeps the empty images.
  o.posTolPx = 1e-6;
  auto strict = vgr::tools::evaluate(o);
  ASSERT_TRUE(strict.has_value());
  EXPECT_EQ(strict->successes, sum->emptyImages);
  o.plotPath = (dir / "errors.png").string();
  ASSERT_TRUE(vgr::tools::plotErrors(*rep, o, o.plotPath).has_value());
  EXPECT_FALSE(cv::imread(o.plotPath).empty());
  fs::remove_all(dir);
}

// A cell config job naming a folder: resolved against the config file's folder; its method,
// grasp height and reference come from job.yaml; keys that job.yaml owns are refused.
TEST(locate_job, CellConfigJobsNameAFolder) {
  const fs::path dir = tempDir("cellfolder");
  fs::create_directories(dir / "jobs" / "bracket");
  auto j = sampleJob(dir / "jobs" / "bracket");
  ASSERT_TRUE(vgr::config::writeJob(j).has_value());
  std::ofstream(dir / "jobs" / "bracket" / "template.png") << "x";  // only its existence is checked here
  std::string yaml = vgr::config::embeddedSimCellYaml();
  const auto a = yaml.find("jobs:\n"), b = yaml.find("\n# Used by the simulators");
  ASSERT_NE(a, std::string::npos);
  ASSERT_NE(b, std::string::npos);
  auto withJob = [&](const std::string& entry) {
    std::string y = yaml;
    y.replace(a, b - a, "jobs:\n  - id: 3\n" + entry);
    return vgr::config::parseCellConfig(y, (dir / "cell.yaml").string());
  };
  auto cfg = withJob("    folder: jobs/bracket\n");
  ASSERT_TRUE(cfg.has_value()) << cfg.error().message;
  EXPECT_EQ(cfg->jobs[0].folder, (dir / "jobs" / "bracket").string());
  EXPECT_EQ(cfg->jobs[0].method, "hu");
  EXPECT_DOUBLE_EQ(cfg->jobs[0].partHeightMm, 35);
  EXPECT_DOUBLE_EQ(cfg->jobs[0].reference.x, 400);
  cfg = withJob("    folder: jobs/bracket\n    method: sift\n");
  ASSERT_TRUE(cfg.has_value()) << cfg.error().message;
  EXPECT_EQ(cfg->jobs[0].method, "sift");
  cfg = withJob("    folder: jobs/bracket\n    threshold: 80\n");
  ASSERT_FALSE(cfg.has_value());
  EXPECT_NE(cfg.error().message.find("key 'jobs[0].threshold': set in the job folder's job.yaml"), std::string::npos)
      << cfg.error().message;
  cfg = withJob("    folder: jobs/nothing\n");
  ASSERT_FALSE(cfg.has_value());
  EXPECT_NE(cfg.error().message.find("key 'jobs[0].folder': " + (dir / "jobs" / "nothing").string() + "/job.yaml: cannot open"),
            std::string::npos) << cfg.error().message;
  cfg = withJob("    method: sift\n");
  ASSERT_FALSE(cfg.has_value());
  EXPECT_NE(cfg.error().message.find("other methods need a job folder"), std::string::npos) << cfg.error().message;
  fs::remove_all(dir);
}

}  // namespace
