// The robot simulators' sorting check (sim/sort_check.hpp): for each of paper 002's part
// orders it passes exactly what the daemon's ResultStore serves, and it catches a missed
// part, a wrong label, a part out of order, a duplicate and a part the truth does not have.
#include <gtest/gtest.h>

#include <map>
#include <vector>

#include <boost/asio/io_context.hpp>

#include "daemon/result_store.hpp"
#include "sim/sort_check.hpp"

namespace {

using vgr::config::PartOrder;
using vgr::sim::checkSorting;
using vgr::sim::RobotGot;

// One frame with five parts of labels 2, 1, 3, 1, 2 (the locator's order, best first) and
// one frame with parts of label 1 only.
struct Fixture {
  std::map<std::uint64_t, std::vector<vgr::sim::CellPartTruth>> truth;
  std::map<std::uint32_t, vgr::sim::JournalCycle> journal;
  std::map<std::uint32_t, vgr::CycleResult> results;

  Fixture() {
    const int labels[2][5] = {{2, 1, 3, 1, 2}, {1, 1, 0, 0, 0}};
    for (std::uint32_t cycle = 1; cycle <= 2; ++cycle) {
      vgr::CycleResult r;
      r.cycleId = cycle;
      r.status = vgr::Status::Ok;
      r.frameId = 100 + cycle;
      vgr::sim::JournalCycle j;
      j.status = 0;
      j.frameId = r.frameId;
      for (int k = 0; k < 5; ++k) {
        const int label = labels[cycle - 1][k];
        if (label == 0) continue;
        vgr::sim::CellPartTruth t;
        t.xMm = 100.0 * k + 0.3;  // the truth: 0.3 mm from what vision found
        t.yMm = 50.0 * cycle;
        t.label = label;
        truth[r.frameId].push_back(t);
        vgr::PartResult p;
        p.pose.x = 100.0 * k;
        p.pose.y = 50.0 * cycle;
        p.label = label;
        p.score = 1.0 - 0.1 * k;
        r.parts.push_back(p);
        j.parts.push_back({p.pose.x, p.pose.y, label});
      }
      journal[cycle] = j;
      results[cycle] = r;
    }
  }

  // What the daemon's ResultStore serves a robot of this order, one reply after another.
  std::vector<RobotGot> served(PartOrder order, int label) const {
    std::vector<RobotGot> out;
    for (const auto& [cycle, r] : results)
      for (const auto& reply : vgr::daemon::ResultStore::replies(r, vgr::daemon::RobotPolicy{1, 100, order, label}))
        out.push_back({vgr::statusCode(reply.status), reply.cycleId, reply.pose.x, reply.pose.y, reply.label, reply.confidence});
    return out;
  }
};

TEST(sort_check, PassesWhatTheDaemonServesForEveryOrder) {
  const Fixture f;
  for (PartOrder order : {PartOrder::BestScore, PartOrder::ByLabel, PartOrder::LabelOnly, PartOrder::Random}) {
    const auto c = checkSorting(order, 2, f.truth, f.journal, f.served(order, 2));
    EXPECT_TRUE(c.ok()) << vgr::sim::partOrderName(order) << ": " << c.firstProblem;
    EXPECT_EQ(c.cycles, 2);
    EXPECT_EQ(c.missed, 0);
    EXPECT_NEAR(c.maxPosErrMm, 0.3, 1e-9);
  }
  // label_only 2: two parts of the first frame, and NO_PART_FOUND for the second.
  const auto c = checkSorting(PartOrder::LabelOnly, 2, f.truth, f.journal, f.served(PartOrder::LabelOnly, 2));
  EXPECT_EQ(c.expected, 2);
  EXPECT_EQ(c.delivered, 2);
}

TEST(sort_check, CatchesEveryKindOfMistake) {
  const Fixture f;
  const auto best = f.served(PartOrder::BestScore, 0);
  {  // one part never delivered
    auto got = best;
    got.erase(got.begin() + 2);
    const auto c = checkSorting(PartOrder::BestScore, 0, f.truth, f.journal, got);
    EXPECT_FALSE(c.ok());
    EXPECT_EQ(c.missed, 1);
  }
  {  // the best-score order swapped
    auto got = best;
    std::swap(got[0], got[1]);
    const auto c = checkSorting(PartOrder::BestScore, 0, f.truth, f.journal, got);
    EXPECT_EQ(c.outOfOrder, 1);
    EXPECT_FALSE(c.ok());
    EXPECT_TRUE(checkSorting(PartOrder::Random, 0, f.truth, f.journal, got).ok());  // random: any order
  }
  {  // best-score order given to a by_label robot
    const auto c = checkSorting(PartOrder::ByLabel, 0, f.truth, f.journal, best);
    EXPECT_GT(c.outOfOrder, 0);
  }
  {  // a wrong label, a duplicate and a part that is not there
    auto got = best;
    got[0].label = 3;
    got.insert(got.begin() + 1, got[1]);
    got.push_back({0, 1, 999.0, 999.0, 1, 0.9});
    const auto c = checkSorting(PartOrder::Random, 0, f.truth, f.journal, got);
    EXPECT_EQ(c.wrongLabel, 1);
    EXPECT_EQ(c.duplicates, 1);
    EXPECT_EQ(c.extra, 1);
  }
  {  // a label_only robot handed a part of another label
    auto got = f.served(PartOrder::LabelOnly, 2);
    got.insert(got.begin(), best[1]);  // label 1
    const auto c = checkSorting(PartOrder::LabelOnly, 2, f.truth, f.journal, got);
    EXPECT_EQ(c.wrongLabel, 1);
    EXPECT_FALSE(c.ok());
  }
  {  // a cycle the robot never heard of
    auto got = best;
    std::erase_if(got, [](const RobotGot& g) { return g.cycle == 2; });
    const auto c = checkSorting(PartOrder::BestScore, 0, f.truth, f.journal, got);
    EXPECT_EQ(c.unseen, 1);
    EXPECT_FALSE(c.ok());
  }
  {  // label_only with nothing to serve must say NO_PART_FOUND
    auto got = f.served(PartOrder::LabelOnly, 2);
    std::erase_if(got, [](const RobotGot& g) { return g.status == 1; });
    got.push_back({2, 2, 0, 0, 0, 0});  // RESULT_NOT_READY does not count
    const auto c = checkSorting(PartOrder::LabelOnly, 2, f.truth, f.journal, got);
    EXPECT_FALSE(c.ok());
  }
}

}  // namespace
