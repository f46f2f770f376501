// job.yaml as config/job.hpp writes it (yaml-cpp's emitter): any name, template, calibration
// path and parameter text round-trips exactly, numbers included; a method parameter's range
// error names the file and line of its `params:` entry (vision/locate/params.hpp).
#include <unistd.h>

#include <cmath>
#include <filesystem>
#include <string>

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "config/dataset_file.hpp"
#include "config/job.hpp"
#include "sim/dataset.hpp"
#include "vision/locate/locator.hpp"

namespace {

namespace fs = std::filesystem;

fs::path tempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / fmt::format("vgr-job-yaml-{}-{}", name, ::getpid());
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

int lineOf(const std::string& text, const std::string& what) {
  const auto at = text.find(what);
  EXPECT_NE(at, std::string::npos) << what;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

const char* const kNastyStrings[] = {
    "box \"A\" C:\\temp", "  leading and trailing spaces  ", "# not a comment", "key: value", "a, b: [c] {d}",
    "two\nlines", "tab\there", "ünïcødé 部品 ✓", "'single' \"double\"", "-", "- item", "~", "null", "true", "0x1F",
    "123", "1e3", "", "&anchor *alias !tag", "%directive", "@at `tick`", "back\\slash\\"};

TEST(job_yaml, NastyStringsRoundTripExactly) {
  const fs::path dir = tempDir("strings");
  for (const char* nasty : kNastyStrings) {
    vgr::config::JobFile j;
    j.folder = dir.string();
    j.name = nasty;
    j.calibration = nasty;
    j.grasps = {{1, 2}};
    j.taught.grasp = j.grasps.front();
    j.taught.params["text"] = nasty;
    if (std::string(nasty) != "") j.templateImage = nasty;
    ASSERT_TRUE(vgr::config::writeJob(j).has_value()) << nasty;
    auto back = vgr::config::loadJob(dir.string());
    ASSERT_TRUE(back.has_value()) << nasty << ": " << back.error().message << "\n" << vgr::config::jobYaml(j);
    EXPECT_EQ(back->name, j.name);
    EXPECT_EQ(back->calibration, j.calibration);
    EXPECT_EQ(back->templateImage, j.templateImage);
    EXPECT_EQ(back->taught.params.at("text"), j.taught.params.at("text"));
  }
  fs::remove_all(dir);
}

TEST(job_yaml, NumbersRoundTripExactly) {
  const fs::path dir = tempDir("numbers");
  vgr::config::JobFile j;
  j.folder = dir.string();
  j.grasps = {{0.1, 1.0 / 3}, {-123456.78901234567, 1e-7}};
  j.taught.grasp = j.grasps.front();
  j.taught.minScore = 0.7000000000000001;
  j.taught.angleMinDeg = -179.99999999999997;
  j.taught.angleMaxDeg = std::nextafter(90.0, 100.0);
  j.partHeightMm = 2.0 / 3;
  j.referenceXMm = -0.0;
  j.referenceYMm = 999999.9999999999;
  j.referenceZMm = 5e-324;
  j.referenceRzDeg = -359.1;
  j.taught.regions.push_back({{{0.30000000000000004, 0}, {10.5, 1e-9}, {std::acos(-1.0), 7}}, 12.345678901234567, 0.1});
  ASSERT_TRUE(vgr::config::writeJob(j).has_value());
  auto back = vgr::config::loadJob(dir.string());
  ASSERT_TRUE(back.has_value()) << back.error().message;
  ASSERT_EQ(back->grasps.size(), 2u);
  for (std::size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back->grasps[i].u, j.grasps[i].u);
    EXPECT_EQ(back->grasps[i].v, j.grasps[i].v);
  }
  EXPECT_EQ(back->taught.minScore, j.taught.minScore);
  EXPECT_EQ(back->taught.angleMinDeg, j.taught.angleMinDeg);
  EXPECT_EQ(back->taught.angleMaxDeg, j.taught.angleMaxDeg);
  EXPECT_EQ(back->partHeightMm, j.partHeightMm);
  EXPECT_EQ(back->referenceXMm, 0.0);
  EXPECT_EQ(back->referenceYMm, j.referenceYMm);
  EXPECT_EQ(back->referenceZMm, j.referenceZMm);
  EXPECT_EQ(back->referenceRzDeg, j.referenceRzDeg);
  ASSERT_EQ(back->taught.regions.size(), 1u);
  EXPECT_EQ(back->taught.regions[0].heightMm, j.taught.regions[0].heightMm);
  EXPECT_EQ(back->taught.regions[0].heightFactor, 0.1);
  ASSERT_EQ(back->taught.regions[0].polygon.size(), 3u);
  for (std::size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back->taught.regions[0].polygon[i].u, j.taught.regions[0].polygon[i].u);
    EXPECT_EQ(back->taught.regions[0].polygon[i].v, j.taught.regions[0].polygon[i].v);
  }
  fs::remove_all(dir);
}

TEST(job_yaml, ParameterErrorsNameFileAndLine) {
  vgr::config::JobFile j;
  j.folder = "JOB";
  j.method = "hu";
  j.grasps = {{10, 10}};
  j.taught.params["min_area_px"] = "50";
  j.taught.params["threshold"] = "300";
  const std::string yaml = vgr::config::jobYaml(j);
  auto job = vgr::config::parseJob(yaml, "JOB/job.yaml", "JOB");
  ASSERT_TRUE(job.has_value()) << job.error().message;
  const auto& src = job->taught.paramSources;
  ASSERT_EQ(src.count("threshold"), 1u);
  EXPECT_EQ(src.at("threshold").file, "JOB/job.yaml");
  EXPECT_EQ(src.at("threshold").line, lineOf(yaml, "threshold:"));

  cv::Mat templ(64, 64, CV_8UC1, cv::Scalar(0));
  templ(cv::Rect(16, 16, 32, 32)).setTo(255);
  auto bad = vgr::vision::makeLocator("hu", templ, job->taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().message,
            fmt::format("hu: parameter 'threshold': expected an integer in [0, 255], got '300' "
                        "(JOB/job.yaml:{}: key 'params.threshold')",
                        lineOf(yaml, "threshold:")));

  job->taught.params.erase("threshold");
  job->taught.params["treshold"] = "10";
  job->taught.paramSources["treshold"] = {"JOB/job.yaml", 7};
  bad = vgr::vision::makeLocator("hu", templ, job->taught);
  ASSERT_FALSE(bad.has_value());
  EXPECT_EQ(bad.error().message, "hu: unknown parameter 'treshold' (did you mean 'threshold'?) (JOB/job.yaml:7: key 'params.treshold')");
}

// What `vgr sim render` writes next to its images loads back through the readers `vgr eval`
// and `vgr teach --regions` use.
TEST(job_yaml, RenderedDatasetFilesLoadBack) {
  const fs::path dir = tempDir("dataset");
  vgr::sim::DatasetOptions d;
  d.outDir = dir.string();
  d.count = 1;
  d.part = "multi";
  d.levels = 3;
  d.scene.width = 320;
  d.scene.height = 256;
  d.scene.seed = 7;
  ASSERT_TRUE(vgr::sim::writeDataset(d).has_value());
  auto ds = vgr::config::loadDatasetFile((dir / "dataset.yaml").string());
  ASSERT_TRUE(ds.has_value()) << ds.error().message;
  EXPECT_EQ(ds->part, "multi");
  EXPECT_EQ(ds->levels, 3);
  EXPECT_EQ(ds->count, 1);
  EXPECT_EQ(ds->seed, 7u);
  EXPECT_EQ(ds->width, 320);
  EXPECT_DOUBLE_EQ(ds->cx, 159.5);
  EXPECT_GT(ds->fx, 0);
  auto tp = vgr::config::loadPartTemplateFile((dir / "template.yaml").string());
  ASSERT_TRUE(tp.has_value()) << tp.error().message;
  EXPECT_EQ(tp->image, "template.png");
  EXPECT_EQ(tp->regions.size(), 3u);
  EXPECT_GT(tp->graspHeightMm, 0);
  auto regions = vgr::config::loadRegions((dir / "template.yaml").string());
  ASSERT_TRUE(regions.has_value()) << regions.error().message;
  EXPECT_EQ(regions->size(), 3u);
  fs::remove_all(dir);
}

TEST(job_yaml, DatasetAndTemplateFilesRoundTrip) {
  const fs::path dir = tempDir("files");
  vgr::config::DatasetFile d;
  d.part = "flat";
  d.count = 12;
  d.seed = 123456789012345ull;
  d.width = 640;
  d.height = 512;
  d.angleRangeDeg = 12.5;
  d.emptyRatio = 0.3;
  d.fx = d.fy = 1000.25;
  d.cx = 319.5;
  d.cy = 255.5;
  d.cameraHeightMm = 500;
  ASSERT_TRUE(vgr::config::writeDatasetFile((dir / "dataset.yaml").string(), d).has_value());
  auto db = vgr::config::loadDatasetFile((dir / "dataset.yaml").string());
  ASSERT_TRUE(db.has_value()) << db.error().message;
  EXPECT_EQ(db->seed, d.seed);
  EXPECT_EQ(db->angleRangeDeg, d.angleRangeDeg);
  EXPECT_EQ(db->emptyRatio, d.emptyRatio);
  EXPECT_EQ(db->fx, d.fx);
  EXPECT_EQ(db->cy, d.cy);
  EXPECT_EQ(db->cameraHeightMm, d.cameraHeightMm);

  vgr::config::PartTemplateFile t;
  t.image = "part #1: \"A\".png";
  t.grasp = {12.5, 7.25};
  t.graspHeightMm = 20;
  t.cropOffsetX = 100;
  t.cropOffsetY = -3;
  t.regions.push_back({{{0, 0}, {10.5, 0}, {10.25, 10}}, 20, 1});
  ASSERT_TRUE(vgr::config::writePartTemplateFile((dir / "template.yaml").string(), t).has_value());
  auto tb = vgr::config::loadPartTemplateFile((dir / "template.yaml").string());
  ASSERT_TRUE(tb.has_value()) << tb.error().message;
  EXPECT_EQ(tb->image, t.image);
  EXPECT_EQ(tb->grasp.u, 12.5);
  EXPECT_EQ(tb->grasp.v, 7.25);
  EXPECT_EQ(tb->graspHeightMm, 20);
  EXPECT_EQ(tb->cropOffsetY, -3);
  ASSERT_EQ(tb->regions.size(), 1u);
  EXPECT_EQ(tb->regions[0].polygon[2].u, 10.25);
  EXPECT_EQ(tb->regions[0].heightFactor, 1);
  fs::remove_all(dir);
}

}  // namespace
