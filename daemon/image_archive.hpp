// The image archive (docs/commissioning.md "Image archive"): the frames of failed cycles
// (any status but OK that had a frame: no part found, a locator error, a late cycle, a
// frame of the wrong size, offset limits) and every N-th OK cycle's frame, kept as lossless
// PNG under `archive.dir` with the cycle's journal line beside it, within a disk quota.
//
// What is stored is exactly the 8-bit gray image the locator was given (a Mono10/12/16
// camera's frame after vision::toGray8), so `vgr replay` runs a job on the very pixels the
// cell located in. Files: <stem>.png and <stem>.json (the journal line, one line), stem
// "YYYYmmdd-HHMMSS.mmm-c<cycle>" from the trigger time (UTC) and the cycle id: name order is
// time order, and the journal line of an archived cycle names its file ("archive").
//
// Cost to the cycle thread: offer() decides, and copies a kept frame into one of `queue`
// preallocated slots (no allocation once warm; a 1280x1024 frame is one ~1.3 MB memcpy).
// Encoding, writing and the quota run on the archive's own thread (nice +5, below the
// cycle thread). A kept frame with no free slot is dropped and counted (its journal line
// then has no "archive" field); a failed write is counted and logged once per burst.
// Quota: before each write the oldest frames go until the new one fits (so the folder never
// holds more than `quota` bytes of frames), and at start over what is already there
// (counted as deleted). A frame larger than the whole quota is not written (a write error).
//
// Threads: start()/stop() on the main thread; offer() on the cycle thread only;
// counters() and list() from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <condition_variable>
#include <cstdint>
#include <deque>
#include <memory>
#include <mutex>
#include <string>
#include <thread>
#include <vector>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "core/result.hpp"

namespace cv {
class Mat;
}

namespace vgr::daemon {

// "20261202-101530.123-c17": the archive's file stem of a cycle (UTC trigger time).
std::string archiveStem(std::uint32_t cycleId, std::chrono::system_clock::time_point triggerTime);
// True for a name archiveStem() can have made, plus ".png" or ".json" when `ext` is given
// (the web server serves only such names: no path can be smuggled in).
bool isArchiveName(const std::string& name, const std::string& ext);
// The folder vgrd archives into: archive.dir, else "archive" next to the journal.
std::string archiveDir(const config::CellConfig& cell);

struct ArchiveCounters {
  std::uint64_t written = 0;      // frames written (PNG + journal line)
  std::uint64_t dropped = 0;      // kept frames dropped: no free slot (the disk fell behind)
  std::uint64_t deleted = 0;      // frames deleted for the quota, oldest first
  std::uint64_t writeErrors = 0;  // frames that could not be written
  std::uint64_t bytes = 0;        // bytes in the archive now (PNG + JSON)
  std::uint64_t files = 0;        // frames in the archive now
  std::uint64_t quotaBytes = 0;
  std::uint64_t queued = 0;       // frames waiting for the disk (the one being written included)
};

struct ArchivedFrame {
  std::string stem;
  std::uint64_t bytes = 0;  // PNG + JSON
};

class ImageArchive {
 public:
  // dir: the resolved archive folder (archive.dir, or "archive" next to the journal).
  ImageArchive(const config::ArchiveConfig& config, std::string dir);
  ~ImageArchive();  // stop()
  ImageArchive(const ImageArchive&) = delete;
  ImageArchive& operator=(const ImageArchive&) = delete;

  // Creates the folder, removes leftover temporary files, indexes what is there (oldest
  // first by name), applies the quota and starts the writer thread. Error names the folder.
  Result<void> start();
  // Writes what is queued, then joins.
  void stop();

  // Cycle thread. Whether this cycle's frame is to be kept (see above); if so and a slot is
  // free, copies `gray` (CV_8UC1) and the result and queues them: returns true, and the
  // caller marks the result archived (CycleResult::archived) before the journal line is
  // written. The journal line written beside the PNG is Journal::toJson of `r` with
  // archived set. Returns false for a frame not kept or dropped.
  bool offer(const CycleResult& r, const cv::Mat& gray);

  ArchiveCounters counters() const;
  // The newest `limit` frames, newest first.
  std::vector<ArchivedFrame> list(std::size_t limit) const;
  const std::string& dir() const { return dir_; }

 private:
  struct Slot;
  void run();
  void write(Slot& slot);
  // Deletes the oldest frames until bytes_ + reserve fit the quota. mutex_ held.
  void applyQuota(std::uint64_t reserve);

  const config::ArchiveConfig cfg_;
  const std::string dir_;
  std::thread thread_;
  mutable std::mutex mutex_;
  std::condition_variable cv_;
  bool stopping_ = false;
  std::vector<std::unique_ptr<Slot>> slots_;
  std::vector<Slot*> free_;      // mutex_
  std::deque<Slot*> pending_;    // mutex_
  bool writing_ = false;         // mutex_: the writer holds a slot
  std::deque<ArchivedFrame> index_;  // mutex_: oldest first
  std::uint64_t okSeen_ = 0;     // cycle thread: OK cycles with a frame
  std::atomic<std::uint64_t> written_{0}, dropped_{0}, deleted_{0}, writeErrors_{0}, bytes_{0};
  std::uint64_t errorBurst_ = 0;  // writer thread
};

}  // namespace vgr::daemon
