// 3D job files (config/job3d.hpp, docs/3d.md "Jobs"): what writeJob3d writes reads back
// exactly; every bad value names the file, its line and the key; `kind` tells 2D and 3D
// jobs apart and each reader refuses the other kind.
#include <unistd.h>

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/core.h>
#include <gtest/gtest.h>

#include "config/job.hpp"
#include "config/job3d.hpp"
#include "core/search3d.hpp"

namespace {

namespace fs = std::filesystem;
using vgr::config::Job3dFile;

fs::path tempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / fmt::format("vgr-job3d-{}-{}", name, ::getpid());
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

int lineOf(const std::string& text, const std::string& what) {
  const auto at = text.find(what);
  EXPECT_NE(at, std::string::npos) << what;
  return 1 + static_cast<int>(std::count(text.begin(), text.begin() + static_cast<long>(at), '\n'));
}

Job3dFile sample() {
  Job3dFile j;
  j.name = "bracket bin: \"left\"";
  j.model = "model.ply";
  j.grasp = {12.5, -3.25, 40, 0.5, 0.5, -0.5, 0.5};
  j.search.voxelMm = 2.5;
  j.search.nRotations = 6;
  j.search.fLow = 0.45;
  j.search.fHigh = 0.9;
  j.search.maxParts = 3;
  j.search.roi = {-185, 185, -135.5, 135, 300, 700};
  j.search.removePlane = false;
  j.search.seed = 42;
  j.search.ransacConfidence = 0.1 + 0.2;  // not a short decimal
  return j;
}

TEST(job3d, WrittenJobReadsBackExactly) {
  const fs::path dir = tempDir("roundtrip");
  Job3dFile j = sample();
  j.folder = dir.string();
  ASSERT_TRUE(vgr::config::writeJob3d(j).has_value());
  auto kind = vgr::config::jobKind(dir.string());
  ASSERT_TRUE(kind.has_value()) << kind.error().message;
  EXPECT_EQ(*kind, "3d");
  auto r = vgr::config::loadJob3d(dir.string());
  ASSERT_TRUE(r.has_value()) << r.error().message;
  EXPECT_EQ(r->name, j.name);
  EXPECT_EQ(r->model, j.model);
  EXPECT_EQ(r->modelPath(), (dir / "model.ply").string());
  EXPECT_EQ(r->grasp.x, j.grasp.x);
  EXPECT_EQ(r->grasp.y, j.grasp.y);
  EXPECT_EQ(r->grasp.z, j.grasp.z);
  EXPECT_EQ(r->grasp.qw, j.grasp.qw);
  EXPECT_EQ(r->grasp.qz, j.grasp.qz);
  for (const auto& key : vgr::search3dKeys()) EXPECT_EQ(key.get(r->search), key.get(j.search)) << key.name;
  EXPECT_EQ(r->search.removePlane, false);
  EXPECT_EQ(r->search.seed, 42u);
  EXPECT_EQ(r->search.roi.xMin, -185);
  EXPECT_EQ(r->search.roi.yMin, -135.5);
  EXPECT_EQ(r->search.roi.zMax, 700);
  fs::remove_all(dir);
}

TEST(job3d, MinimalJobTakesTheDocumentedDefaults) {
  auto r = vgr::config::parseJob3d("version: 1\nkind: 3d\n", "JOB/job.yaml", "JOB");
  ASSERT_TRUE(r.has_value()) << r.error().message;
  const vgr::Search3dParams d;
  for (const auto& key : vgr::search3dKeys()) EXPECT_EQ(key.get(r->search), key.get(d)) << key.name;
  EXPECT_EQ(r->model, "model.ply");
  EXPECT_EQ(r->grasp.qw, 1);
  EXPECT_EQ(r->grasp.x, 0);
}

struct BadCase {
  const char* yaml;
  const char* lineHolds;  // the text on the line the error must name
  const char* key;        // as in the message: key 'KEY'
  const char* what;       // part of the message
};

TEST(job3d, EveryBadValueNamesFileLineAndKey) {
  const BadCase cases[] = {
      {"version: 1\nkind: 3d\nsearch:\n  voxel_mm: 3\n  f_h: 2\n", "f_h: 2", "search.f_h", "expected a number in [0, 1], got '2'"},
      {"version: 1\nkind: 3d\nsearch:\n  n_r: 2.5\n", "n_r: 2.5", "search.n_r", "integer"},
      {"version: 1\nkind: 3d\nsearch:\n  f_l: 0.6\n  f_h: 0.5\n", "f_h: 0.5", "search.f_h", "below f_l"},
      {"version: 1\nkind: 3d\nsearch:\n  f_l: 0.3\n  retry_min_fitness: 0.4\n", "retry_min_fitness", "search.retry_min_fitness",
       "above f_l"},
      {"version: 1\nkind: 3d\nsearch:\n  cluster_mm: -1\n", "cluster_mm", "search.cluster_mm", "expected a number in [0, 100], got '-1'"},
      {"version: 1\nkind: 3d\nsearch:\n  voxel_mm: 3\n  max_below_plane_mm: x\n", "max_below_plane_mm", "search.max_below_plane_mm",
       "expected a number"},
      {"version: 1\nkind: 3d\nsearch:\n  feature_neighbours: 11\n", "feature_neighbours", "search.feature_neighbours", "[1, 10]"},
      {"version: 1\nkind: 3d\nsearch:\n  voxle_mm: 3\n", "voxle_mm", "search.voxle_mm", "unknown key"},
      {"version: 1\nkind: 3d\nsearch:\n  roi: {x_min: 10, x_max: -10}\n", "roi:", "search.roi", "x_min must be below x_max"},
      {"version: 1\nkind: 3d\nsearch:\n  roi: {z_min: 100, z_max: 50}\n", "roi:", "search.roi", "z_min must be below z_max"},
      {"version: 1\nkind: 3d\nsearch:\n  remove_plane: perhaps\n", "remove_plane", "search.remove_plane", "true or false"},
      {"version: 1\nkind: 3d\ngrasp: {x_mm: 1, qw: 1, qx: 1}\n", "grasp:", "grasp.qw", "not unit length"},
      {"version: 1\nkind: 3d\ngrasp: {x_mm: nan}\n", "grasp:", "grasp.x_mm", "expected a number"},
      {"version: 1\nkind: 3d\nmodel: \"\"\n", "model:", "model", "expected a file name"},
      {"version: 1\nname: x\n", "", "kind", ""},
      {"version: 1\nkind: 2d\n", "kind: 2d", "kind", "expected 3d"},
      {"version: 2\nkind: 3d\n", "version: 2", "version", ""},
      {"version: 1\nkind: 3d\nthreshold: 3\n", "threshold", "threshold", "unknown key"},
  };
  for (const auto& c : cases) {
    auto r = vgr::config::parseJob3d(c.yaml, "JOB/job.yaml", "JOB");
    ASSERT_FALSE(r.has_value()) << c.yaml;
    const std::string& m = r.error().message;
    const std::string text = c.yaml;
    if (*c.lineHolds) EXPECT_NE(m.find(fmt::format("JOB/job.yaml:{}:", lineOf(text, c.lineHolds))), std::string::npos) << m;
    else EXPECT_EQ(m.rfind("JOB/job.yaml:", 0), 0u) << m;
    EXPECT_NE(m.find(fmt::format("key '{}'", c.key)), std::string::npos) << m;
    EXPECT_NE(m.find(c.what), std::string::npos) << m;
  }
}

TEST(job3d, KindSeparatesTheReaders) {
  const fs::path dir = tempDir("kind");
  auto write = [&](const std::string& text) { std::ofstream(dir / "job.yaml") << text; };

  write("version: 1\nmethod: moments\n");
  auto k2 = vgr::config::jobKind(dir.string());
  ASSERT_TRUE(k2.has_value()) << k2.error().message;
  EXPECT_EQ(*k2, "2d");

  write("version: 1\n\nkind: 4d\n");
  auto bad = vgr::config::jobKind(dir.string());
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("job.yaml:3: key 'kind': expected 2d or 3d, got '4d'"), std::string::npos)
      << bad.error().message;

  // The 2D reader refuses a 3D job with a pointer to the 3D reader.
  write("version: 1\nkind: 3d\n");
  auto j2 = vgr::config::loadJob(dir.string());
  ASSERT_FALSE(j2.has_value());
  EXPECT_NE(j2.error().message.find(":2: key 'kind'"), std::string::npos) << j2.error().message;
  EXPECT_NE(j2.error().message.find("3D job"), std::string::npos) << j2.error().message;

  EXPECT_FALSE(vgr::config::loadJob3d((dir / "missing").string()).has_value());
  EXPECT_FALSE(vgr::config::jobKind((dir / "missing").string()).has_value());
  fs::remove_all(dir);
}

}  // namespace
