// vgrd's image archive (daemon/image_archive.hpp, docs/commissioning.md) in the simulated
// cell, the short form of the 10-minute run (bench/archive_bench.py is the long one):
// a PLC triggering at ~10 Hz, every 10th frame an empty belt (the emulator's --empty-every),
// a quota of 4 MB that the run overflows several times (a queue of 64 slots, so that a
// loaded test machine slows the writer without dropping frames: drops are the unit test's). Checked:
//   - the folder never holds more than the quota (sampled after every cycle) and the
//     metrics' vgr_archive_bytes is what is on disk;
//   - what is left is exactly the newest archived frames: every file the journal names from
//     the oldest one still there on is there, so every failed cycle of the last quota's
//     worth is there and referenced from its journal line ("archive");
//   - every failed cycle was archived, every 5th OK one too, nothing was dropped;
//   - each PNG is the very frame the camera served (the renderer's frame for its frame_id,
//     pixel for pixel), and the JSON beside it is the cycle's journal line.
#include <filesystem>
#include <fstream>
#include <set>

#include <opencv2/imgcodecs.hpp>

#include "modbus_cell.hpp"
#include "sim/cell_scenes.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace {

using namespace std::chrono_literals;
namespace fs = std::filesystem;
using vgr::test::ModbusCell;

constexpr std::uint64_t kQuota = 4'000'000;

std::uint64_t folderBytes(const fs::path& dir) {
  std::uint64_t total = 0;
  std::error_code ec;
  for (const auto& e : fs::directory_iterator(dir, ec))
    if (e.path().extension() != ".tmp") total += fs::file_size(e.path(), ec);
  return total;
}

double metric(const std::string& text, const std::string& name) {
  const auto at = text.find("\n" + name + " ");
  return at == std::string::npos ? -1 : std::stod(text.substr(at + name.size() + 2));
}

class archive_vgrd : public ModbusCell {};

TEST_F(archive_vgrd, StaysWithinQuotaKeepsEveryRecentFailureReferencedFromTheJournal) {
  const int port = vgr::test::freeLoopbackPort();
  ASSERT_GT(port, 0);
  ASSERT_NO_FATAL_FAILURE(prepareCell([port](std::string yaml) {
    return yaml + "\nweb:\n  bind: 127.0.0.1\n  port: " + std::to_string(port) +
           "\n  page: false\narchive:\n  quota_mb: 4\n  every_nth_good: 5\n  queue: 64\n";
  }));
  camera_ = vgr::test::startEmulator({"--config", configPath_, "--empty-every", "10"}, (dir_ / "camera.log").string());
  ASSERT_NE(camera_, nullptr);
  ASSERT_NO_FATAL_FAILURE(startVgrd());
  const fs::path archive = dir_ / "archive";  // next to the journal (archive.dir unset)
  ASSERT_TRUE(fs::is_directory(archive)) << log("vgrd.log");

  constexpr int kCycles = 60;
  std::uint64_t peak = 0;
  modbus_t* ctx = modbus_new_tcp("127.0.0.1", kModbusPort);
  ASSERT_NE(ctx, nullptr);
  ASSERT_EQ(modbus_connect(ctx), 0);
  for (int i = 1; i <= kCycles; ++i) {
    const auto r = triggerCounter(ctx, static_cast<std::uint16_t>(i), 5s);
    ASSERT_TRUE(r.status & 0x08) << "RESULT_VALID, cycle " << i << "\n" << log("vgrd.log");
    peak = std::max(peak, folderBytes(archive));
    std::this_thread::sleep_for(100ms);
  }
  modbus_close(ctx);
  modbus_free(ctx);
  ASSERT_FALSE(journalEntry(kCycles).is_null());
  // The writer (a niced thread, behind the cycles on a loaded machine) finishes the last frames.
  std::string metrics;
  for (auto until = Clock::now() + 30s; Clock::now() < until; std::this_thread::sleep_for(100ms)) {
    peak = std::max(peak, folderBytes(archive));
    metrics = vgr::test::httpRequest(static_cast<std::uint16_t>(port), "GET", "/metrics");
    if (metric(metrics, "vgr_archive_queued") == 0) break;
  }
  peak = std::max(peak, folderBytes(archive));

  const auto lines = journal();
  ASSERT_EQ(lines.size(), static_cast<std::size_t>(kCycles));
  std::vector<std::string> named;  // archive files the journal names, oldest first
  int failed = 0, ok = 0, okArchived = 0;
  for (const auto& j : lines) {
    const bool hasFrame = j["frame_id"].get<std::uint64_t>() > 0;
    if (j["status"] != 0) {
      ++failed;
      EXPECT_TRUE(hasFrame) << j.dump();
      EXPECT_TRUE(j.contains("archive")) << "a failed cycle's frame is archived: " << j.dump();
    } else {
      ++ok;
      if (j.contains("archive")) ++okArchived;
    }
    if (j.contains("archive")) named.push_back(j["archive"]);
  }
  EXPECT_GE(failed, 5) << "every 10th frame is an empty belt";
  EXPECT_EQ(okArchived, ok / 5) << "every 5th OK cycle";

  // Within the quota, all the time, and the metrics say what is on disk.
  EXPECT_LE(peak, kQuota);
  metrics = vgr::test::httpRequest(static_cast<std::uint16_t>(port), "GET", "/metrics");
  EXPECT_EQ(metric(metrics, "vgr_archive_bytes"), static_cast<double>(folderBytes(archive))) << metrics;
  EXPECT_EQ(metric(metrics, "vgr_archive_quota_bytes"), static_cast<double>(kQuota));
  EXPECT_EQ(metric(metrics, "vgr_archive_dropped_total"), 0);
  EXPECT_GT(metric(metrics, "vgr_archive_deleted_total"), 0) << "the run must overflow the quota to test it";
  EXPECT_EQ(metric(metrics, "vgr_archive_written_total"), static_cast<double>(named.size()));

  // What is left is the newest named frames without a gap.
  std::size_t firstPresent = named.size();
  for (std::size_t i = 0; i < named.size(); ++i)
    if (fs::exists(archive / named[i])) {
      firstPresent = i;
      break;
    }
  ASSERT_LT(firstPresent, named.size()) << "nothing left in the archive";
  EXPECT_GT(firstPresent, 0u) << "the oldest were deleted";
  std::set<std::string> files;
  for (const auto& e : fs::directory_iterator(archive)) files.insert(e.path().filename().string());
  EXPECT_EQ(files.size(), 2 * (named.size() - firstPresent)) << "a PNG and a JSON per frame, nothing else";
  const vgr::sim::CellScenes scenes(cfg_);
  for (std::size_t i = firstPresent; i < named.size(); ++i) {
    ASSERT_TRUE(fs::exists(archive / named[i])) << named[i] << ": a gap in the newest frames";
    const auto& j = *std::find_if(lines.begin(), lines.end(), [&](const auto& l) { return l.value("archive", "") == named[i]; });
    const std::string stem = named[i].substr(0, named[i].size() - 4);
    std::ifstream side(archive / (stem + ".json"));
    std::string sideLine;
    std::getline(side, sideLine);
    EXPECT_EQ(nlohmann::json::parse(sideLine), j) << "the JSON beside the PNG is the journal line";
    const cv::Mat png = cv::imread((archive / named[i]).string(), cv::IMREAD_UNCHANGED);
    ASSERT_EQ(png.type(), CV_8UC1);
    if (j["status"] == 0) {
      cv::Mat served;
      scenes.render(j["frame_id"].get<std::uint64_t>(), served);
      EXPECT_EQ(cv::norm(png, served, cv::NORM_INF), 0) << named[i] << ": not the frame the camera served";
    }
  }
  std::printf("archive: %zu frames named by the journal, %zu left (%.2f MB of %.2f MB), peak %.2f MB\n", named.size(),
              named.size() - firstPresent, folderBytes(archive) / 1e6, kQuota / 1e6, peak / 1e6);
}

}  // namespace
