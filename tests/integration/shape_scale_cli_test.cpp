// The scale range as a user sets it (issue 18, "Scale"): `vgr teach --method shape
// --scale-min 0.5 --scale-max 1.5` writes scale_min/scale_max into job.yaml, `vgr locate
// --json` reports each part's `scale`, and a job whose scale_max is below its scale_min is
// refused naming file, line and key (exit 2). Images from sim/shape_scenes.hpp (a 24-tooth
// gear, 160 px in the template, noise sigma 5).
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <regex>
#include <sstream>
#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/imgcodecs.hpp>

#include "sim/shape_scenes.hpp"
#include "tests/support/command.hpp"
#include "tests/support/temp_dir_test.hpp"

namespace {

namespace fs = std::filesystem;
namespace shapes = vgr::sim::shapes;

class shape_scale_cli : public vgr::test::TempDirTest {};

std::string slurp(const fs::path& p) {
  std::ifstream in(p);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

std::string teach(const fs::path& dir, const shapes::ShapeTemplate& tp) {
  std::ostringstream s;
  s << "teach --image " << (dir / "template.png").string() << " --grasp " << tp.graspU << "," << tp.graspV;
  return s.str();
}

TEST_F(shape_scale_cli, TeachWithAScaleRangeLocateReportsTheScale) {
  const auto part = shapes::gear(160);
  const auto tp = shapes::renderTemplate(part, 10, 5, 3);
  ASSERT_TRUE(cv::imwrite((dir_ / "template.png").string(), tp.image));
  shapes::ShapeSceneOptions o;
  o.size = {640, 480};
  o.clutter = 3;
  o.illumRatio = 1.5;
  shapes::ShapePose pose;
  pose.u = 330.4, pose.v = 241.7, pose.angleDeg = -71.3, pose.scale = 1.37;
  cv::Mat img;
  shapes::renderScene(part, {pose}, o, img);
  ASSERT_TRUE(cv::imwrite((dir_ / "scene.png").string(), img));

  const std::string job = (dir_ / "job").string();
  auto r = vgr::test::runVgr(teach(dir_, tp) + " --method shape --scale-min 0.5 --scale-max 1.5 --out " + job);
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const std::string yaml = slurp(dir_ / "job" / "job.yaml");
  EXPECT_NE(yaml.find("scale_min: 0.5"), std::string::npos) << yaml;
  EXPECT_NE(yaml.find("scale_max: 1.5"), std::string::npos) << yaml;

  r = vgr::test::runVgr("locate --job " + job + " --image " + (dir_ / "scene.png").string() + " --json");
  ASSERT_EQ(r.exitCode, 0) << r.out;
  const auto j = nlohmann::json::parse(vgr::test::lastLine(r.out));
  ASSERT_EQ(j["parts"].size(), 1u) << r.out;
  const auto& p = j["parts"][0];
  EXPECT_NEAR(p["scale"].get<double>(), 1.37, 1.37 * 0.002);
  EXPECT_NEAR(p["x_px"].get<double>(), pose.u, 0.3);
  EXPECT_NEAR(p["y_px"].get<double>(), pose.v, 0.3);

  // A fixed-scale job (the default) on the same image: no part, not a wrong one.
  const std::string fixed = (dir_ / "fixed").string();
  r = vgr::test::runVgr(teach(dir_, tp) + " --method shape --out " + fixed);
  ASSERT_EQ(r.exitCode, 0) << r.out;
  EXPECT_NE(slurp(dir_ / "fixed" / "job.yaml").find("scale_min: 1"), std::string::npos);
  r = vgr::test::runVgr("locate --job " + fixed + " --image " + (dir_ / "scene.png").string() + " --json");
  EXPECT_EQ(r.exitCode, 0) << r.out;
  EXPECT_EQ(nlohmann::json::parse(vgr::test::lastLine(r.out))["parts"].size(), 0u) << r.out;

  // scale_max below scale_min: refused on load with file:line:key.
  std::string broken = yaml;
  broken.replace(broken.find("scale_max: 1.5"), 14, "scale_max: 0.4");
  std::ofstream(dir_ / "job" / "job.yaml") << broken;
  r = vgr::test::runVgr("locate --job " + job + " --image " + (dir_ / "scene.png").string() + " --json");
  EXPECT_EQ(r.exitCode, 2) << r.out;
  EXPECT_TRUE(std::regex_search(r.out, std::regex("job\\.yaml:[0-9]+: key 'scale_max': must not be below scale_min"))) << r.out;
}

}  // namespace
