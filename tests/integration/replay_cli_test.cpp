// `vgr replay` (tools/vgr/replay.hpp, docs/commissioning.md): vgrd runs a taught `shape`
// job on the simulated cell's textured parts with every frame archived; then
//   - the unchanged job replayed on the archive reproduces every cycle (exit 0, 0 differ):
//     the same pixels, the same locator, the same mapping as vgrd;
//   - the job with min_score raised between two scores the cell delivered reports exactly
//     the cycles whose result changes (found independently: `vgr locate` of the changed job
//     on each archived PNG), each OK -> NO_PART_FOUND, and nothing else (exit 1); those
//     include every cycle scored below the new min_score;
//   - a frame deleted from the archive is counted missing; bad input exits 2.
#include <algorithm>
#include <filesystem>
#include <fstream>
#include <regex>
#include <set>

#include <opencv2/imgcodecs.hpp>

#include "modbus_cell.hpp"
#include "sim/cell_scenes.hpp"
#include "tests/support/command.hpp"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using vgr::test::ModbusCell;

class replay_cli : public ModbusCell {
 protected:
  void TearDown() override {
    ModbusCell::TearDown();
    std::error_code ec;
    if (!HasFailure()) fs::remove_all(jobRoot_, ec);
  }
  fs::path jobRoot_;
};

TEST_F(replay_cli, ReportsExactlyTheFramesAChangedMinScoreChanges) {
  // Teach `shape` on the part renderer's template (as locate_vgrd_methods_test does).
  jobRoot_ = fs::temp_directory_path() / ("vgr-replay-" + std::to_string(::getpid()));
  fs::remove_all(jobRoot_);
  fs::create_directories(jobRoot_);
  {
    std::string yaml = vgr::config::embeddedSimCellYaml();
    yaml.replace(yaml.find("\nsim:\n"), 6, "\nsim:\n  scene: part\n");
    const auto cell = vgr::config::parseCellConfig(yaml, "cell.yaml");
    ASSERT_TRUE(cell.has_value());
    const vgr::sim::CellScenes scenes(*cell);
    cv::Mat templ;
    const auto t = scenes.partRenderer()->renderTemplate(templ);
    ASSERT_TRUE(cv::imwrite((jobRoot_ / "template.png").string(), templ));
    const auto taught = vgr::test::runVgr("teach --image " + (jobRoot_ / "template.png").string() + " --grasp " +
                                          std::to_string(t.graspU) + "," + std::to_string(t.graspV) +
                                          " --method shape --min-score 0.5 --out " + (jobRoot_ / "job").string());
    ASSERT_EQ(taught.exitCode, 0) << taught.out;
  }
  const std::string job = (jobRoot_ / "job").string();
  ASSERT_NO_FATAL_FAILURE(startCell([&job](std::string yaml) {
    const auto a = yaml.find("jobs:\n"), b = yaml.find("\n# Used by the simulators");
    yaml.replace(a, b - a, "jobs:\n  - id: 1\n    name: part\n    folder: " + job + "\n");
    yaml.replace(yaml.find("\nsim:\n"), 6, "\nsim:\n  scene: part\n");
    yaml.replace(yaml.find("cycle_deadline_ms: 1500"), 23, "cycle_deadline_ms: 10000");  // timing-free (see locate_vgrd_methods)
    return yaml + "\narchive:\n  every_nth_good: 1\n  quota_mb: 200\n  queue: 64\n";  // no drops on a loaded machine
  }));
  constexpr int kCycles = 14;
  std::vector<std::uint32_t> cycles;
  ASSERT_NO_FATAL_FAILURE(triggerCycles(kCycles, 1, 10s, cycles));
  ASSERT_FALSE(journalEntry(cycles.back()).is_null());
  const std::string archive = (dir_ / "archive").string();
  // The archive writes behind the cycles (a niced thread): wait for every frame the journal names.
  for (auto until = Clock::now() + 30s; Clock::now() < until; std::this_thread::sleep_for(100ms)) {
    bool all = true;
    for (const auto& j : journal()) all = all && j.contains("archive") && fs::exists(fs::path(archive) / j["archive"].get<std::string>());
    if (all) break;
  }
  const std::string base = "replay --journal " + journalPath() + " --archive " + archive + " --config " + configPath_;

  // 1. The unchanged job reproduces every cycle.
  const auto same = vgr::test::runVgr(base + " --job " + job + " --json");
  ASSERT_EQ(same.exitCode, 0) << same.out;
  const auto s = nlohmann::json::parse(vgr::test::lastLine(same.out), nullptr, false);
  ASSERT_TRUE(s.is_object()) << same.out;
  EXPECT_EQ(s["summary"]["frames"], kCycles);
  EXPECT_EQ(s["summary"]["compared"], kCycles);
  EXPECT_EQ(s["summary"]["differ"], 0) << s.dump(2);

  // 2. min_score between two delivered scores: exactly the cycles below it change.
  std::vector<std::pair<double, std::uint32_t>> scores;
  for (const auto& j : journal()) {
    ASSERT_EQ(j["status"], 0) << j.dump();
    scores.push_back({j["parts"][0]["score"].get<double>(), j["cycle"].get<std::uint32_t>()});
  }
  std::sort(scores.begin(), scores.end());
  // The widest gap in the middle half of the scores (journal scores carry 3 decimals).
  std::size_t cut = 0;
  double gap = 0;
  for (std::size_t i = scores.size() / 4; i + 1 < scores.size() * 3 / 4 + 1; ++i)
    if (scores[i + 1].first - scores[i].first > gap) gap = scores[i + 1].first - scores[i].first, cut = i;
  // Two different journal scores suffice: the journal rounds half away from zero
  // (daemon/journal.cpp round3), so a score written as 0.989 is below 0.9895 and one written
  // as 0.990 is at or above it, and the midpoint below is that boundary. (The 14 scores of
  // these images lie within ~0.008, in 0.001 steps: a 0.002 gap was there by chance.)
  ASSERT_GE(gap, 0.001 - 1e-9) << "the scores do not spread enough to put a threshold between them";
  const double threshold = (scores[cut].first + scores[cut + 1].first) / 2;

  const fs::path changed = jobRoot_ / "job-changed";
  fs::copy(job, changed, fs::copy_options::recursive);
  std::string yaml;
  {
    std::ifstream in(changed / "job.yaml");
    yaml.assign(std::istreambuf_iterator<char>(in), std::istreambuf_iterator<char>());
  }
  yaml = std::regex_replace(yaml, std::regex("min_score: [0-9.]+"), "min_score: " + std::to_string(threshold));
  std::ofstream(changed / "job.yaml") << yaml;
  // What changes, found without replay: `vgr locate` of the changed job on each archived
  // PNG, its status against the journal's. (For `shape`, min_score also prunes the search
  // pyramid, so a raise can lose a part whose final score is above it: not only the cycles
  // scored below it change.)
  std::set<std::uint32_t> expected;
  for (const auto& j : journal()) {
    const auto l = vgr::test::runVgr("locate --json --job " + changed.string() + " --image " + archive + "/" +
                                     j["archive"].get<std::string>());
    const auto lj = nlohmann::json::parse(vgr::test::lastLine(l.out), nullptr, false);
    ASSERT_TRUE(lj.is_object()) << l.out;
    if (lj["status"] != j["status"]) expected.insert(j["cycle"].get<std::uint32_t>());
  }
  for (std::size_t i = 0; i <= cut; ++i)
    EXPECT_TRUE(expected.count(scores[i].second)) << "cycle " << scores[i].second << " scored " << scores[i].first
                                                  << " < " << threshold << " and is still found";
  ASSERT_FALSE(expected.empty());
  ASSERT_LT(expected.size(), scores.size()) << "the threshold must leave some cycles as they were";

  const auto diff = vgr::test::runVgr(base + " --job " + changed.string() + " --job-id 1 --json");
  EXPECT_EQ(diff.exitCode, 1) << diff.out;
  const auto d = nlohmann::json::parse(vgr::test::lastLine(diff.out), nullptr, false);
  ASSERT_TRUE(d.is_object()) << diff.out;
  std::set<std::uint32_t> reported;
  for (const auto& f : d["frames"]) {
    EXPECT_EQ(f["differs"], true);
    EXPECT_EQ(f["delivered"]["status"], 0);
    EXPECT_EQ(f["now"]["status"], 1) << f.dump();
    reported.insert(f["cycle"].get<std::uint32_t>());
  }
  EXPECT_EQ(reported, expected) << "threshold " << threshold << "\n" << d.dump(2);
  EXPECT_EQ(d["summary"]["differ"], expected.size());
  EXPECT_EQ(d["summary"]["same"], scores.size() - expected.size());
  EXPECT_EQ(d["summary"]["status_changed"], expected.size());
  EXPECT_EQ(d["summary"]["transitions"]["OK -> NO_PART_FOUND"], expected.size());

  // Text output: one line per differing frame and the sum; the progress bar on request.
  const auto text = vgr::test::runVgr(base + " --job " + changed.string() + " --job-id 1 --progress");
  EXPECT_EQ(text.exitCode, 1);
  EXPECT_NE(text.out.find(std::to_string(kCycles) + "/" + std::to_string(kCycles)), std::string::npos) << text.out;
  EXPECT_NE(text.out.find(std::to_string(expected.size()) + " differ"), std::string::npos) << text.out;
  EXPECT_NE(text.out.find("status 0 OK -> 1 NO_PART_FOUND"), std::string::npos) << text.out;

  // 3. A frame the quota deleted is missing, not compared.
  const std::string gone = journal().front()["archive"];
  fs::remove(fs::path(archive) / gone);
  const auto missing = vgr::test::runVgr(base + " --job " + job + " --json");
  EXPECT_EQ(missing.exitCode, 0) << missing.out;
  const auto m = nlohmann::json::parse(vgr::test::lastLine(missing.out), nullptr, false);
  EXPECT_EQ(m["summary"]["missing"], 1);
  EXPECT_EQ(m["summary"]["compared"], kCycles - 1);

  // Bad input: exit 2 with the reason.
  EXPECT_EQ(vgr::test::runVgr(base + " --job " + (jobRoot_ / "nothing").string()).exitCode, 2);
  const auto noJournal = vgr::test::runVgr("replay --journal /nonexistent.jsonl --archive " + archive + " --config " + configPath_ +
                                           " --job " + job);
  EXPECT_EQ(noJournal.exitCode, 2);
  EXPECT_NE(noJournal.out.find("/nonexistent.jsonl"), std::string::npos) << noJournal.out;
}

}  // namespace
