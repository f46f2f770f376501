// The image archive's rules (daemon/image_archive.hpp) on a real folder: which frames are
// kept (every failed cycle with a frame, every N-th OK one), the PNG holds exactly the
// image given (lossless), the journal line beside it is Journal::toJson with "archive"
// naming the file, the quota deletes the oldest first and is never exceeded, a restart
// indexes what is there and applies a smaller quota, a full queue drops and counts.
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>

#include <chrono>
#include <filesystem>
#include <fstream>
#include <thread>

#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "daemon/image_archive.hpp"
#include "daemon/journal.hpp"

namespace vgr::daemon {
namespace {

namespace fs = std::filesystem;
using namespace std::chrono_literals;

class image_archive : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("vgr-archive-test-" + std::to_string(::getpid()) + "-" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
  }
  void TearDown() override {
    if (!HasFailure()) fs::remove_all(dir_);
  }

  static CycleResult result(std::uint32_t id, Status status) {
    CycleResult r;
    r.cycleId = id;
    r.jobId = 1;
    r.status = status;
    r.triggerTime = std::chrono::system_clock::time_point(std::chrono::milliseconds(1795326914000LL + id * 200));
    if (status == Status::Ok) {
      PartResult p;
      p.pose.x = 100 + id;
      p.uPx = 10.5;
      p.vPx = 20.25;
      p.score = 0.9;
      r.parts.push_back(p);
    }
    return r;
  }

  // A noisy frame (PNG cannot shrink it much), different per id.
  static cv::Mat frame(std::uint32_t id, int w = 320, int h = 240) {
    cv::Mat m(h, w, CV_8UC1);
    cv::RNG rng(id);
    rng.fill(m, cv::RNG::UNIFORM, 0, 256);
    return m;
  }

  // Waits until the archive has written `n` frames in all (20 s at most: the writer is niced).
  static void waitWritten(const ImageArchive& a, std::uint64_t n) {
    const auto until = std::chrono::steady_clock::now() + 20s;
    while (a.counters().written + a.counters().writeErrors < n && std::chrono::steady_clock::now() < until)
      std::this_thread::sleep_for(2ms);
  }

  std::uint64_t folderBytes() const {
    std::uint64_t total = 0;
    for (const auto& e : fs::directory_iterator(dir_)) total += fs::file_size(e.path());
    return total;
  }

  fs::path dir_;
};

TEST_F(image_archive, StemNamesSortByTimeAndOnlyOursAreAccepted) {
  const auto t = std::chrono::system_clock::time_point(std::chrono::milliseconds(1795326914728LL));
  EXPECT_EQ(archiveStem(17, t), "20261122-055514.728-c17");
  EXPECT_LT(archiveStem(9, t), archiveStem(8, t + 1ms));
  EXPECT_TRUE(isArchiveName("20261202-022834.728-c17.png", ".png"));
  EXPECT_TRUE(isArchiveName("20261202-022834.728-c17", ""));
  EXPECT_FALSE(isArchiveName("../20261202-022834.728-c17.png", ".png"));
  EXPECT_FALSE(isArchiveName("20261202-022834.728-c17.png/../x", ".png"));
  EXPECT_FALSE(isArchiveName("20261202-022834.728-c17.json", ".png"));
  EXPECT_FALSE(isArchiveName("", ".png"));
}

TEST_F(image_archive, KeepsFailedCyclesAndEveryNthGoodOneLosslessWithTheirJournalLine) {
  config::ArchiveConfig cfg;
  cfg.enabled = true;
  cfg.everyNthGood = 3;
  cfg.queue = 64;
  cfg.quotaBytes = 100'000'000;
  ImageArchive a(cfg, dir_.string());
  ASSERT_TRUE(a.start().has_value());
  std::vector<std::uint32_t> kept;
  for (std::uint32_t id = 1; id <= 12; ++id) {
    const Status st = id % 4 == 0 ? Status::NoPartFound : (id == 7 ? Status::ProcessingTimeout : Status::Ok);
    const bool took = a.offer(result(id, st), frame(id));
    if (took) kept.push_back(id);
  }
  // OK cycles: 1 2 3 5 6 9 10 11 -> the 3rd and 6th OK (3, 9) are kept; failed: 4 7 8 12.
  EXPECT_EQ(kept, (std::vector<std::uint32_t>{3, 4, 7, 8, 9, 12}));
  // No frame, nothing to keep.
  EXPECT_FALSE(a.offer(result(13, Status::CameraError), cv::Mat()));
  waitWritten(a, kept.size());
  a.stop();
  const ArchiveCounters c = a.counters();
  EXPECT_EQ(c.written, kept.size());
  EXPECT_EQ(c.dropped, 0u);
  EXPECT_EQ(c.files, kept.size());
  EXPECT_EQ(c.bytes, folderBytes());
  for (std::uint32_t id : kept) {
    CycleResult r = result(id, id % 4 == 0 ? Status::NoPartFound : (id == 7 ? Status::ProcessingTimeout : Status::Ok));
    const std::string stem = archiveStem(id, r.triggerTime);
    const cv::Mat back = cv::imread((dir_ / (stem + ".png")).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(back.type(), CV_8UC1) << stem;
    EXPECT_EQ(cv::norm(back, frame(id), cv::NORM_INF), 0) << stem << ": not the image given";
    std::ifstream in(dir_ / (stem + ".json"));
    std::string line;
    std::getline(in, line);
    r.archived = true;
    EXPECT_EQ(line, Journal::toJson(r)) << "the journal line vgrd writes for this cycle";
    EXPECT_EQ(nlohmann::json::parse(line)["archive"], stem + ".png");
  }
}

TEST_F(image_archive, QuotaDeletesTheOldestFirstAndIsNeverExceeded) {
  config::ArchiveConfig cfg;
  cfg.enabled = true;
  cfg.everyNthGood = 0;
  cfg.queue = 64;
  // A 320x240 noise frame is ~77 kB as PNG: room for 5 of them, not 6.
  cfg.quotaBytes = 420'000;
  ImageArchive a(cfg, dir_.string());
  ASSERT_TRUE(a.start().has_value());
  std::uint64_t peak = 0;
  for (std::uint32_t id = 1; id <= 20; ++id) {
    ASSERT_TRUE(a.offer(result(id, Status::NoPartFound), frame(id)));
    waitWritten(a, id);
    peak = std::max(peak, folderBytes());
  }
  a.stop();
  const ArchiveCounters c = a.counters();
  EXPECT_EQ(c.written, 20u);
  EXPECT_LE(peak, cfg.quotaBytes);
  EXPECT_LE(c.bytes, cfg.quotaBytes);
  EXPECT_EQ(c.bytes, folderBytes());
  EXPECT_EQ(c.files + c.deleted, 20u);
  ASSERT_GE(c.files, 4u);
  // What is left is the newest frames, without a gap.
  const auto list = a.list(100);
  ASSERT_EQ(list.size(), c.files);
  for (std::size_t i = 0; i < list.size(); ++i) {
    const std::uint32_t id = 20 - static_cast<std::uint32_t>(i);
    EXPECT_EQ(list[i].stem, archiveStem(id, result(id, Status::NoPartFound).triggerTime));
  }

  // A restart with a smaller quota: the oldest go at start, the newest stay.
  cfg.quotaBytes = 200'000;
  ImageArchive b(cfg, dir_.string());
  std::ofstream(dir_ / "20261202-000000.000-c1.png.tmp") << "cut short";
  ASSERT_TRUE(b.start().has_value());
  EXPECT_FALSE(fs::exists(dir_ / "20261202-000000.000-c1.png.tmp")) << "a temporary file left by a crash is removed";
  const ArchiveCounters d = b.counters();
  EXPECT_LE(d.bytes, cfg.quotaBytes);
  EXPECT_EQ(d.bytes, folderBytes());
  ASSERT_GE(d.files, 1u);
  EXPECT_EQ(b.list(1).front().stem, archiveStem(20, result(20, Status::NoPartFound).triggerTime));
  b.stop();
}

TEST_F(image_archive, AFullQueueDropsAndCounts) {
  config::ArchiveConfig cfg;
  cfg.enabled = true;
  cfg.everyNthGood = 0;
  cfg.queue = 1;
  cfg.quotaBytes = 100'000'000;
  ImageArchive a(cfg, dir_.string());
  ASSERT_TRUE(a.start().has_value());
  // 1600x1200 noise takes the writer tens of ms to encode: offers in a burst find the one slot busy.
  int took = 0;
  constexpr int kOffers = 20;
  for (std::uint32_t id = 1; id <= kOffers; ++id) took += a.offer(result(id, Status::NoPartFound), frame(id, 1600, 1200));
  a.stop();
  const ArchiveCounters c = a.counters();
  EXPECT_LT(took, kOffers);
  EXPECT_EQ(c.dropped, static_cast<std::uint64_t>(kOffers - took));
  EXPECT_EQ(c.written, static_cast<std::uint64_t>(took));
}

TEST_F(image_archive, AFolderThatCannotBeMadeIsAnErrorNamingIt) {
  config::ArchiveConfig cfg;
  cfg.enabled = true;
  fs::create_directories(dir_);
  std::ofstream(dir_ / "file") << "x";
  ImageArchive a(cfg, (dir_ / "file" / "archive").string());
  const auto r = a.start();
  ASSERT_FALSE(r.has_value());
  EXPECT_NE(r.error().message.find((dir_ / "file" / "archive").string()), std::string::npos) << r.error().message;
}

}  // namespace
}  // namespace vgr::daemon
