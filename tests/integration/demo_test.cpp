// `vgr demo`, as the README's first command runs it: the whole simulated cell (camera
// emulator, vgrd mapping with the example's calibration files, PLC and three robot
// simulators) for a few cycles, scored against the renderer's truth; and `--method`, which
// teaches a job of another method on the textured part and runs the cell with it.

#include <map>
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

// Paper 002's sorting cell (issue 15): three classes mixed, a classifier the demo trains, four
// robots with best_score, by_label, label_only (label 2) and random orders and reply_label on;
// each robot simulator checks that it got exactly the parts its order says against the
// renderer's truth, and the summary says so. Failed before: --classes did not exist.
TEST(demo, SortingRobotsGetExactlyThePartsTheirOrderSays) {
  const DemoRun r = demo("--cycles 4 --classes ring,square,rect_notch");
  ASSERT_EQ(r.rc, 0) << r.out;
  const auto s = summary(r.out);
  ASSERT_TRUE(s.is_object()) << r.out;
  EXPECT_EQ(s["ok"].get<int>(), 4) << r.out;
  EXPECT_TRUE(s["sorting_ok"].get<bool>()) << r.out;
  EXPECT_EQ(s["plc_label_errors"].get<int>(), 0) << r.out;
  const std::map<std::string, std::string> orders{{"ur5", "best_score"}, {"irb", "by_label"}, {"lrmate", "label_only"}, {"picker", "random"}};
  for (const auto& [robot, order] : orders) {
    const auto& c = s["sorting"][robot];
    ASSERT_TRUE(c.is_object()) << robot << "\n" << r.out;
    EXPECT_EQ(c["order"], order) << robot;
    EXPECT_TRUE(c["ok"].get<bool>()) << robot << ": " << c.dump();
    EXPECT_EQ(c["cycles"].get<int>(), 4) << robot;
    EXPECT_GT(c["delivered"].get<int>(), 0) << robot;
    EXPECT_EQ(c["delivered"].get<int>(), c["expected"].get<int>()) << robot;
    EXPECT_LT(c["max_pos_err_mm"].get<double>(), 2.0) << robot;  // the moments centroid vs the truth's grasp point
  }
  // The label_only robot got a strict subset of what the best_score robot got.
  EXPECT_LT(s["sorting"]["lrmate"]["delivered"].get<int>(), s["sorting"]["ur5"]["delivered"].get<int>());
}

TEST(demo, SortingRefusesAMethodThatFindsOneShapeOnly) {
  const DemoRun r = demo("--cycles 1 --classes ring,square --method shape");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("moments"), std::string::npos) << r.out;
}

TEST(demo, AnUnknownMethodIsNamed) {
  const DemoRun r = demo("--cycles 1 --method nosuch");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("nosuch"), std::string::npos) << r.out;
}

}  // namespace

namespace {

// `vgr demo --3d` (issue 14): the simulated 3D cell — depth camera emulator over GigE Vision,
// vgrd with the example 3D job and the depth hand-eye, the PLC and the UR, ABB (quaternion)
// and FANUC robot simulators. Every pose delivered is within 1 mm and 1 deg of the
// renderer's truth in the robot base frame (through the TRUE camera pose: the calibration's
// error counts), every robot reply is well-formed and equal to the journal in six DoF.
// The localizer's recall is not 100 % today (docs/demo.md "3D", docs/3d.md "Measured"): a
// cycle without a pose must be a typed 1 NO_PART_FOUND / 4 RETRY_NEW_VIEWPOINT, never a
// wrong pose; the demo's exit code is 0 only at N/N, so this test reads the figures instead.
TEST(demo, ThreeDCellDeliversSixDofPosesWithinOneMillimetreAndOneDegree) {
  const DemoRun r = demo("--3d --cycles 5");
  const auto s = summary(r.out);
  ASSERT_TRUE(s.is_object()) << r.out;
  EXPECT_TRUE(r.rc == 0 || r.rc == 1) << r.out;
  EXPECT_GE(s["ok"].get<int>(), 1) << r.out;
  EXPECT_LE(s["max_pos_err_mm"].get<double>(), 1.0) << r.out;
  EXPECT_LE(s["max_angle_err_deg"].get<double>(), 1.0) << r.out;
  EXPECT_TRUE(s["within_bounds"].get<bool>()) << r.out;
  int cycles = 0;
  for (const auto& [code, n] : s["statuses"].items()) {
    EXPECT_TRUE(code == "0" || code == "1" || code == "4") << "a cycle ended " << code << ": " << r.out;
    cycles += n.get<int>();
  }
  EXPECT_EQ(cycles, 5) << "every cycle answered: " << r.out;
  // Three robots, every reply well-formed and equal to the journal.
  for (const char* robot : {"ur5", "irb", "lrmate"}) {
    const std::string line = std::string("robot ") + robot + ":";
    const auto at = r.out.find(line);
    ASSERT_NE(at, std::string::npos) << r.out;
    const std::string l = r.out.substr(at, r.out.find('\n', at) - at);
    EXPECT_NE(l.find(" 0 malformed"), std::string::npos) << l;
    EXPECT_NE(l.find(" 0 not matching the journal"), std::string::npos) << l;
  }
}

TEST(demo, ThreeDRefusesTheOptionsOfThe2dCell) {
  const DemoRun r = demo("--3d --cycles 1 --method shape");
  EXPECT_EQ(r.rc, 2) << r.out;
  EXPECT_NE(r.out.find("--3d runs the embedded"), std::string::npos) << r.out;
}

}  // namespace
