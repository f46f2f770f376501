// `vgr demo`, as the README's first command runs it: the whole simulated cell (camera
// emulator, vgrd mapping with the example's calibration files, PLC and three robot
// simulators) for a few cycles, scored against the renderer's truth; and `--method`, which
// teaches a job of another method on the textured part and runs the cell with it.

#include <string>

#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include "tests/support/command.hpp"

namespace {

struct DemoRun {
  int rc = -1;
  std::string out;
};

DemoRun demo(const std::string& args) {
  const auto r = vgr::test::runCommand(vgr::test::binPath("vgr") + " demo --quiet " + args + " 2>&1");
  return {r.exitCode, r.out};
}

nlohmann::json summary(const std::string& out) {
  const auto at = out.rfind("{\"cycles\"");
  return at == std::string::npos ? nlohmann::json() : nlohmann::json::parse(out.substr(at), nullptr, false);
}

// Every cycle delivered a pose within docs/demo.md's bar (0.5 mm, 0.5 deg) of the truth.
void expectEveryCycleTrue(const DemoRun& r, int cycles) {
  const auto s = summary(r.out);
  ASSERT_TRUE(s.is_object()) << r.out;
  EXPECT_EQ(s["ok"].get<int>(), cycles) << r.out;
  EXPECT_LT(s["max_pos_err_mm"].get<double>(), 0.5) << r.out;
  EXPECT_LT(s["max_angle_err_deg"].get<double>(), 0.5) << r.out;
}

TEST(demo, TheExampleCellDeliversTruePosesThroughItsCalibrationFiles) {
  const DemoRun r = demo("--cycles 8");
  ASSERT_EQ(r.rc, 0) << r.out;
  expectEveryCycleTrue(r, 8);
}

TEST(demo, MethodTeachesAJobOnTheTexturedPartAndRunsTheCellWithIt) {
  const DemoRun r = demo("--cycles 8 --method shape");
  ASSERT_EQ(r.rc, 0) << r.out;
  EXPECT_NE(r.out.find("taught a job of method shape"), std::string::npos) << r.out;
  expectEveryCycleTrue(r, 8);
}

TEST(demo, HeightAwareMethodOnTheMultiHeightPartGraspsTheBoss) {
  // The grasp point is on a 35 mm boss: mapped at that height, against the truth there.
  const DemoRun r = demo("--cycles 6 --method shape --scene multi");
  ASSERT_EQ(r.rc, 0) << r.out;
  expectEveryCycleTrue(r, 6);
}

TEST(demo, MethodWithAConfigOfOnesOwnIsRefusedWithAHint) {
  const DemoRun r = demo("--cycles 1 --method shape --config " + std::string(VGR_SOURCE_DIR) + "/config/examples/sim-cell.yaml");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("vgr teach"), std::string::npos) << r.out;
}

TEST(demo, AnUnknownMethodIsNamed) {
  const DemoRun r = demo("--cycles 1 --method nosuch");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("nosuch"), std::string::npos) << r.out;
}

}  // namespace
