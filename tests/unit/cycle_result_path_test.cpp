// The result path of a cycle with labelled detections, end to end without a camera:
// detections (as a classifying locator reports them) -> vision::partPoses (the one
// detections -> poses function vgrd and `vgr locate` use) -> CycleResult -> every sink:
// the robots' ResultStore (part_order by_label / label_only), the PLC's registers
// (protocol::modbusResultFrom + ModbusMap, LABEL at register 22) and the journal.
#include <gtest/gtest.h>

#include <chrono>
#include <cmath>
#include <algorithm>
#include <optional>
#include <vector>

#include <boost/asio/io_context.hpp>
#include <nlohmann/json.hpp>

#include "daemon/journal.hpp"
#include "daemon/result_store.hpp"
#include "protocol/modbus_map.hpp"
#include "vision/calib/pixel_mapping.hpp"
#include "vision/part_poses.hpp"

namespace vgr::daemon {
namespace {

using namespace std::chrono_literals;

vision::Detection det(double u, double v, double score, int label) {
  vision::Detection d;
  d.u = u;
  d.v = v;
  d.score = score;
  d.label = label;
  d.confidence = 0.5 + 0.1 * label + 0.02 * score;  // distinct per part
  return d;
}

// The simulated cell's camera: 1000 px focal, 500 mm above the plane, looking down.
vision::PinholePlaneModel simCamera() {
  return vision::PinholePlaneModel(1000, 1000, 639.5, 511.5, vision::PinholePlaneModel::downLookingCamera(400, 0, 500, 90), 0);
}

CycleResult labelledResult() {
  // Best score first, as a locator reports them; labels out of order.
  const std::vector<vision::Detection> found{det(600, 500, 0.95, 2), det(700, 400, 0.90, 1), det(500, 600, 0.80, 2),
                                             det(650, 650, 0.70, 1)};
  const auto mapping = vision::calib::pinholeMapping(simCamera());
  CycleResult r;
  r.cycleId = 7;
  r.jobId = 1;
  r.status = Status::Ok;
  r.trigger = TriggerSource::Robot;
  r.parts = vision::partPoses(found, *mapping, vision::PartPoseRules{});
  return r;
}

TEST(cycle_result_path, part_poses_carry_label_score_and_pixels) {
  const CycleResult r = labelledResult();
  ASSERT_EQ(r.parts.size(), 4u);
  const int labels[] = {2, 1, 2, 1};
  const double scores[] = {0.95, 0.90, 0.80, 0.70};
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(r.parts[i].label, labels[i]) << i;
    EXPECT_DOUBLE_EQ(r.parts[i].score, scores[i]) << i;
  }
  EXPECT_DOUBLE_EQ(r.parts[1].uPx, 700);
  EXPECT_DOUBLE_EQ(r.parts[1].vPx, 400);
  // The pixel maps where the camera model says: project the pose back.
  const auto px = simCamera().project({r.parts[1].pose.x, r.parts[1].pose.y, r.parts[1].pose.z});
  ASSERT_TRUE(px);
  EXPECT_NEAR(px->u, 700, 1e-6);
  EXPECT_NEAR(px->v, 400, 1e-6);
}

TEST(cycle_result_path, robots_are_served_by_label) {
  boost::asio::io_context io;
  ResultStore store(io, {1});
  store.addRobot("sorter", RobotPolicy{1, 100, PartOrder::ByLabel, 0});
  store.addRobot("picker", RobotPolicy{1, 100, PartOrder::LabelOnly, 2});
  const CycleResult r = labelledResult();
  store.onResult(r);
  auto ask = [&](const std::string& robot) {
    std::optional<protocol::RobotReply> got;
    store.handle(robot, protocol::RobotRequest{protocol::Command::Get, 1, false, std::nullopt},
                 [&](const protocol::RobotReply& reply) { got = reply; });
    for (int i = 0; i < 100 && !got; ++i) {
      io.restart();
      io.run_for(5ms);
    }
    return got;
  };
  // by_label: label 1 first (best score first within it), then label 2.
  for (int i : {1, 3, 0, 2}) {
    const auto got = ask("sorter");
    ASSERT_TRUE(got);
    EXPECT_EQ(got->status, Status::Ok);
    EXPECT_DOUBLE_EQ(got->pose.x, r.parts[i].pose.x) << "expected part " << i;
  }
  // label_only 2: parts 0 and 2, then nothing new.
  for (int i : {0, 2}) {
    const auto got = ask("picker");
    ASSERT_TRUE(got);
    EXPECT_DOUBLE_EQ(got->pose.x, r.parts[i].pose.x) << "expected part " << i;
  }
  const auto none = ask("picker");
  ASSERT_TRUE(none);
  EXPECT_NE(none->status, Status::Ok);
}

TEST(cycle_result_path, plc_registers_and_journal_carry_label_and_trigger) {
  const CycleResult r = labelledResult();
  const protocol::ModbusResult m = protocol::modbusResultFrom(r);
  EXPECT_EQ(m.label, 2);
  EXPECT_EQ(m.numFound, 4);
  protocol::ModbusMap map;
  map.publishResult(m);
  EXPECT_EQ(map.input(protocol::modbus::kLabel), 2);
  EXPECT_EQ(map.holding(protocol::modbus::kLabel), 2);

  const auto j = nlohmann::json::parse(Journal::toJson(r));
  EXPECT_EQ(j["trigger"], "robot");
  ASSERT_EQ(j["parts"].size(), 4u);
  EXPECT_EQ(j["parts"][0]["label"], 2);
  EXPECT_EQ(j["parts"][1]["label"], 1);
}

// The classifier's confidence reaches every sink with its label: the part poses, the PLC's
// registers (23: x 1000 int16, 38-39: float32), the journal and the robot replies.
TEST(cycle_result_path, confidence_reaches_every_sink) {
  const CycleResult r = labelledResult();
  ASSERT_EQ(r.parts.size(), 4u);
  EXPECT_DOUBLE_EQ(r.parts[0].confidence, 0.5 + 0.2 + 0.02 * 0.95);
  const protocol::ModbusResult m = protocol::modbusResultFrom(r);
  EXPECT_DOUBLE_EQ(m.confidence, r.parts[0].confidence);
  protocol::ModbusMap map;
  map.publishResult(m);
  EXPECT_EQ(map.input(protocol::modbus::kConfidenceInt), 719);  // 0.719 x 1000
  EXPECT_EQ(map.holding(protocol::modbus::kConfidenceInt), 719);
  EXPECT_FLOAT_EQ(protocol::modbus::unpackFloat(map.input(protocol::modbus::kConfidence),
                                                map.input(protocol::modbus::kConfidence + 1), protocol::WordOrder::HighWordFirst),
                  0.719f);
  // The existing registers did not move.
  EXPECT_EQ(protocol::modbus::kLabel, 22);
  EXPECT_EQ(protocol::modbus::kScore, 36);
  EXPECT_EQ(protocol::modbus::kXInt, 40);

  const auto j = nlohmann::json::parse(Journal::toJson(r));
  EXPECT_DOUBLE_EQ(j["parts"][1]["confidence"].get<double>(), 0.618);  // label 1, score 0.9

  const auto replies = ResultStore::replies(r, RobotPolicy{1, 100, PartOrder::BestScore, 0});
  ASSERT_EQ(replies.size(), 4u);
  for (std::size_t i = 0; i < 4; ++i) {
    EXPECT_EQ(replies[i].label, r.parts[i].label);
    EXPECT_DOUBLE_EQ(replies[i].confidence, r.parts[i].confidence);
  }
}

// Paper 002's random selection: every part once, in an order drawn from the cycle id (the
// same on every call for one result), not always the locator's.
TEST(cycle_result_path, random_order_serves_every_part_once) {
  CycleResult r = labelledResult();
  int differs = 0;
  for (std::uint32_t cycle = 1; cycle <= 40; ++cycle) {
    r.cycleId = cycle;
    const auto a = ResultStore::replies(r, RobotPolicy{1, 100, PartOrder::Random, 0});
    const auto b = ResultStore::replies(r, RobotPolicy{1, 100, PartOrder::Random, 0});
    ASSERT_EQ(a.size(), 4u);
    std::vector<double> xs;
    bool same = true, inLocatorOrder = true;
    for (std::size_t i = 0; i < 4; ++i) {
      xs.push_back(a[i].pose.x);
      same = same && a[i].pose.x == b[i].pose.x;
      inLocatorOrder = inLocatorOrder && a[i].pose.x == r.parts[i].pose.x;
    }
    EXPECT_TRUE(same) << "cycle " << cycle;
    std::sort(xs.begin(), xs.end());
    std::vector<double> want;
    for (const auto& p : r.parts) want.push_back(p.pose.x);
    std::sort(want.begin(), want.end());
    EXPECT_EQ(xs, want) << "cycle " << cycle;
    differs += inLocatorOrder ? 0 : 1;
  }
  EXPECT_GT(differs, 20);  // 23 of 24 permutations differ from the locator's order
}

}  // namespace
}  // namespace vgr::daemon
