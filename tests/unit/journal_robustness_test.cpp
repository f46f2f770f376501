// The cycle journal after a crash and on a failing disk (daemon/journal.hpp): a torn last
// line (kill -9 or power loss mid-write) is set apart on open and every complete line kept;
// write errors are counted; the last cycle id is read back so ids continue across restarts.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <filesystem>
#include <fstream>
#include <random>
#include <sstream>
#include <string>
#include <vector>

#include "daemon/cycle_runner.hpp"
#include "daemon/journal.hpp"

namespace vgr::daemon {
namespace {

namespace fs = std::filesystem;

CycleResult cycle(std::uint32_t id) {
  CycleResult r;
  r.cycleId = id;
  r.jobId = 1;
  r.status = Status::Ok;
  return r;
}

std::string slurp(const fs::path& p) {
  std::ifstream in(p, std::ios::binary);
  std::ostringstream s;
  s << in.rdbuf();
  return s.str();
}

std::vector<std::string> lines(const std::string& text) {
  std::vector<std::string> out;
  std::istringstream in(text);
  for (std::string l; std::getline(in, l);) out.push_back(l);
  return out;
}

class journal_robustness : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::path(::testing::TempDir()) / ("vgr_journal_" + std::to_string(::getpid()));
    fs::remove_all(dir_);
    fs::create_directories(dir_);
    path_ = dir_ / "journal.jsonl";
  }
  void TearDown() override { fs::remove_all(dir_); }
  std::vector<fs::path> tornFiles() const {
    std::vector<fs::path> out;
    for (const auto& e : fs::directory_iterator(dir_)) {
      if (e.path().filename().string().rfind("journal.jsonl.torn-", 0) == 0) out.push_back(e.path());
    }
    return out;
  }
  fs::path dir_, path_;
};

TEST_F(journal_robustness, TornLastLineIsSetApartAndTheNextRecordIsReadable) {
  std::string complete;
  for (std::uint32_t id = 1; id <= 3; ++id) complete += Journal::toJson(cycle(id)) + "\n";
  const std::string torn = Journal::toJson(cycle(4)).substr(0, 17);
  std::ofstream(path_, std::ios::binary) << complete << torn;
  {
    Journal j;
    ASSERT_TRUE(j.open(path_.string()));
    j.append(cycle(5));
  }
  const auto l = lines(slurp(path_));
  ASSERT_EQ(l.size(), 4u) << slurp(path_);
  for (const auto& line : l) EXPECT_FALSE(nlohmann::json::parse(line, nullptr, false).is_discarded()) << line;
  EXPECT_EQ(nlohmann::json::parse(l.back())["cycle"], 5);
  const auto set = tornFiles();
  ASSERT_EQ(set.size(), 1u);
  EXPECT_EQ(slurp(set.front()), torn);
}

// A journal cut at random bytes (power loss): every restart keeps all complete lines.
TEST_F(journal_robustness, TruncatedAtRandomBytesEveryRestartKeepsTheCompleteLines) {
  std::mt19937 rng(19);
  std::uint32_t next = 1;
  for (int round = 0; round < 100; ++round) {
    {
      Journal j;
      ASSERT_TRUE(j.open(path_.string()));
      ASSERT_EQ(j.lastCycleId(), next - 1) << "round " << round;
      for (int k = 0; k < 3; ++k) j.append(cycle(next++));
    }
    const std::string text = slurp(path_);
    const std::size_t cut = std::uniform_int_distribution<std::size_t>(text.size() / 2, text.size())(rng);
    fs::resize_file(path_, cut);
    // What a restart must keep: every line complete before the cut.
    const std::string kept = text.substr(0, text.rfind('\n', cut == 0 ? 0 : cut - 1) + 1);
    next = kept.empty() ? 1 : nlohmann::json::parse(lines(kept).back())["cycle"].get<std::uint32_t>() + 1;
    if (cut == text.size()) continue;
    Journal j;
    ASSERT_TRUE(j.open(path_.string()));
    EXPECT_EQ(slurp(path_), kept) << "round " << round;
  }
  for (const auto& line : lines(slurp(path_))) EXPECT_FALSE(nlohmann::json::parse(line, nullptr, false).is_discarded()) << line;
}

TEST_F(journal_robustness, WriteErrorsAreCounted) {
  Journal j;
  ASSERT_TRUE(j.open("/dev/full"));
  for (std::uint32_t id = 1; id <= 5; ++id) j.append(cycle(id));
  EXPECT_EQ(j.writeErrors(), 5u);
}

TEST_F(journal_robustness, LastCycleIdIsReadBack) {
  {
    Journal j;
    ASSERT_TRUE(j.open(path_.string()));
    EXPECT_EQ(j.lastCycleId(), 0u);
    j.append(cycle(41));
    j.append(cycle(42));
  }
  Journal j;
  ASSERT_TRUE(j.open(path_.string()));
  EXPECT_EQ(j.lastCycleId(), 42u);
}

// A size limit with rotation: journal.jsonl -> .1 -> .2 ... up to keepFiles; every record
// is in exactly one file, complete, and ids run on across the files.
TEST_F(journal_robustness, RotatesAtTheSizeLimitAndKeepsTheNewestFiles) {
  JournalOptions o;
  o.maxBytes = 64 * 1024;
  o.keepFiles = 3;
  o.syncMs = -1;
  const std::size_t lineBytes = Journal::toJson(cycle(1000)).size() + 1;
  const std::uint32_t records = static_cast<std::uint32_t>(5 * o.maxBytes / lineBytes + 10);
  {
    Journal j;
    ASSERT_TRUE(j.open(path_.string(), o));
    for (std::uint32_t id = 1000; id < 1000 + records; ++id) j.append(cycle(id));
    EXPECT_EQ(j.stats().rotations, 5u);
    EXPECT_EQ(j.stats().records, records);
  }
  EXPECT_FALSE(fs::exists(path_.string() + ".4")) << "only keepFiles rotated files are kept";
  std::vector<std::uint32_t> ids;
  for (const std::string suffix : {".3", ".2", ".1", ""}) {
    const fs::path f = path_.string() + suffix;
    ASSERT_TRUE(fs::exists(f)) << f;
    if (!suffix.empty()) {
      EXPECT_GE(fs::file_size(f), o.maxBytes) << f;
    }
    for (const auto& line : lines(slurp(f))) {
      const auto j = nlohmann::json::parse(line, nullptr, false);
      ASSERT_FALSE(j.is_discarded()) << f << ": " << line;
      ids.push_back(j["cycle"].get<std::uint32_t>());
    }
  }
  for (std::size_t i = 1; i < ids.size(); ++i) ASSERT_EQ(ids[i], ids[i - 1] + 1) << "at " << i;
  EXPECT_EQ(ids.back(), 1000 + records - 1);
}

// Restarting right after a rotation (the new file empty): ids continue after the newest
// rotated file's last record, not at 1.
TEST_F(journal_robustness, IdsContinueAfterARotationLeftTheJournalEmpty) {
  {
    Journal j;
    ASSERT_TRUE(j.open(path_.string()));
    j.append(cycle(77));
  }
  fs::rename(path_, path_.string() + ".1");
  std::ofstream(path_).close();
  Journal j;
  ASSERT_TRUE(j.open(path_.string()));
  EXPECT_EQ(j.lastCycleId(), 77u);
}

// The fdatasync policy: 0 = after every record, -1 = never, N ms = at most every N ms.
TEST_F(journal_robustness, SyncPolicy) {
  const auto syncsWith = [&](int syncMs, const char* name) {
    JournalOptions o;
    o.syncMs = syncMs;
    Journal j;
    EXPECT_TRUE(j.open((dir_ / name).string(), o));
    for (std::uint32_t id = 1; id <= 20; ++id) j.append(cycle(id));
    return j.stats().syncs;
  };
  EXPECT_EQ(syncsWith(0, "every.jsonl"), 20u);
  EXPECT_EQ(syncsWith(-1, "never.jsonl"), 0u);
  EXPECT_LE(syncsWith(60000, "minute.jsonl"), 1u);
}

TEST(cycle_ids, ContinueAfterTheJournalsLastAndWrapBelow2To23) {
  EXPECT_EQ(firstCycleIdAfter(0), 1u);
  EXPECT_EQ(firstCycleIdAfter(42), 43u);
  EXPECT_EQ(firstCycleIdAfter(kMaxCycleId - 1), kMaxCycleId);
  EXPECT_EQ(firstCycleIdAfter(kMaxCycleId), 1u);
  EXPECT_EQ(firstCycleIdAfter(0xFFFFFFFFu), 1u);
}

}  // namespace
}  // namespace vgr::daemon
