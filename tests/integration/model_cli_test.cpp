// `vgr model build` and `vgr model eval` as a user runs them (docs/3d.md "Model building";
// issue 13): rendered views of the housing with one view's reported position 20 mm off ->
// a 3D job whose report names that view and its edges, whose model lies within 0.3 mm of
// the true mesh, and which finds the part in the data set's scene without a false pose.
// Bad input: exit code 2, one line naming the file, nothing written.
#include <cmath>
#include <filesystem>
#include <fstream>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include "tests/support/command.hpp"
#include "tests/support/temp_dir_test.hpp"

namespace {

namespace fs = std::filesystem;

using vgr::test::lastLine;

vgr::test::CommandResult vgr(const std::string& args) { return vgr::test::runVgr(args); }

class model_cli : public vgr::test::TempDirTest {};

TEST_F(model_cli, BuildFromViewsWithABadRobotPoseThenEvalAndLocate) {
  auto r = vgr("sim render --3d --part housing --count 1 --seed 1 --bad-view 3 --out " + path("set"));
  ASSERT_EQ(r.exitCode, 0) << r.out;
  r = vgr("model build --views " + path("set/views") + " --out " + path("job") + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto j = nlohmann::json::parse(lastLine(r.out));
  EXPECT_EQ(j["views"], 12);
  EXPECT_EQ(j["views_used"], 11) << j.dump();
  const auto& bad = j["report"]["views"][3];
  EXPECT_EQ(bad["view"], "view_03.png");
  EXPECT_FALSE(bad["used"].get<bool>());
  EXPECT_GT(bad["pose_disagreement_mm"].get<double>(), 10.0);
  int named = 0;
  for (const auto& e : j["report"]["edges"])
    if (e["why"].get<std::string>().find("view_03.png's reported pose") != std::string::npos) ++named;
  EXPECT_GT(named, 0) << "no edge rejected for view_03's pose";
  for (const char* f : {"job.yaml", "model.ply", "model_report.json"}) EXPECT_TRUE(fs::is_regular_file(path("job/") + f)) << f;

  r = vgr("model eval --job " + path("job") + " --mesh " + path("set/mesh.ply") + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto m = nlohmann::json::parse(lastLine(r.out));
  EXPECT_LE(m["mean_mm"].get<double>(), 0.3) << m.dump();
  EXPECT_TRUE(m.contains("p95_mm"));

  // The built model finds the housing in the set's scene (as the true model does,
  // cloud_cli), and never a wrong pose.
  r = vgr("eval --job " + path("job") + " --dataset " + path("set") + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto e = nlohmann::json::parse(lastLine(r.out));
  EXPECT_EQ(e["false_positives"], 0) << e.dump();
  EXPECT_EQ(e["success_rate"].get<double>(), 1.0) << e.dump();

  // vgr locate on a 3D job: the same scene, the pose within 2 mm of the truth (truth.csv's
  // row: image,x_mm,y_mm,z_mm,...), the camera found next to the image's folder.
  r = vgr("locate --job " + path("job") + " --image " + path("set/images/0000.png") + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto l = nlohmann::json::parse(lastLine(r.out));
  EXPECT_EQ(l["outcome"], "found") << l.dump();
  ASSERT_EQ(l["parts"].size(), 1u) << l.dump();
  std::ifstream truth(path("set/truth.csv"));
  std::string header, row;
  std::getline(truth, header);
  std::getline(truth, row);
  std::stringstream fields(row);
  std::string image, x, y, z;
  std::getline(fields, image, ',');
  std::getline(fields, x, ',');
  std::getline(fields, y, ',');
  std::getline(fields, z, ',');
  const auto& pose = l["parts"][0]["pose"];
  const double dx = pose["x_mm"].get<double>() - std::stod(x), dy = pose["y_mm"].get<double>() - std::stod(y),
               dz = pose["z_mm"].get<double>() - std::stod(z);
  EXPECT_LE(std::sqrt(dx * dx + dy * dy + dz * dz), 2.0) << l.dump() << " vs " << row;
  // 2D-only options on a 3D job are refused.
  r = vgr("locate --job " + path("job") + " --image " + path("set/images/0000.png") + " --overlay " + path("o.png"));
  EXPECT_EQ(r.exitCode, 2) << r.out;
}

TEST_F(model_cli, BadInputWritesNothing) {
  auto r = vgr("sim render --3d --part lever --count 1 --seed 4 --views 4 --out " + path("set"));
  ASSERT_EQ(r.exitCode, 0) << r.out;
  // A view listed in views.csv whose image is missing.
  fs::copy(path("set"), path("gap"), fs::copy_options::recursive);
  fs::remove(path("gap/views/view_02.png"));
  r = vgr("model build --views " + path("gap/views") + " --out " + path("job"));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("view_02.png"), std::string::npos) << r.out;
  // No camera.yaml next to the views.
  fs::copy(path("set"), path("nocam"), fs::copy_options::recursive);
  fs::remove(path("nocam/camera.yaml"));
  r = vgr("model build --views " + path("nocam/views") + " --out " + path("job"));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("camera.yaml"), std::string::npos) << r.out;
  // No such folder; an existing output folder.
  r = vgr("model build --views " + path("none") + " --out " + path("job"));
  EXPECT_EQ(r.exitCode, 2);
  fs::create_directories(path("taken"));
  r = vgr("model build --views " + path("set/views") + " --out " + path("taken"));
  EXPECT_EQ(r.exitCode, 2);
  EXPECT_NE(r.out.find("already exists"), std::string::npos) << r.out;
  EXPECT_FALSE(fs::exists(path("job")));
  for (const auto& f : fs::directory_iterator(dir_))
    EXPECT_EQ(f.path().filename().string().find("job.partial"), std::string::npos) << f.path();
  // model eval: a mesh that is not there, a job that is not 3D.
  r = vgr("model eval --job " + path("none") + " --mesh " + path("set/mesh.ply"));
  EXPECT_EQ(r.exitCode, 2);
}

}  // namespace
