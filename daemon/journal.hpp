// The append-only cycle journal: one JSON object per line, per cycle (fields in
// docs/journal.md). Written from the cycle thread after the result was handed to the PLC
// and robots, so a slow disk never delays a reply.
//
// Crash safety (docs/journal.md): open() finds a last line without its '\n' (kill -9 or
// power loss mid-write), moves those bytes to <path>.torn-<unix seconds>, truncates the
// journal after its last complete line and logs what it set apart; every complete line is
// kept. Each record is one write() of the whole line to an O_APPEND descriptor. A short
// write is ended with '\n' at once so the next record starts on a line of its own.
// Sync policy (JournalOptions::syncMs): fdatasync() after a record when syncMs have passed
// since the last one (0: after every record; -1: never, the kernel writes back within its
// dirty-page expiry, ~30 s). A power loss costs at most the records of the last syncMs.
// Rotation: when the file reaches maxBytes it becomes <path>.1 (.1 -> .2 ... up to
// <path>.<keepFiles>, the oldest is deleted) and a new file starts; on open, ids continue
// after the last record of <path>, or of <path>.1 when <path> is empty.
// Write errors (full disk, I/O error) are counted (writeErrors()) and logged once per
// burst: the first failure after a success, and the recovery with the count.
// Thread: open() before the cycle thread starts; append() from the cycle thread;
// writeErrors(), lastCycleId() and stats() from any thread.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <string>
#include <vector>

#include "config/cell_config.hpp"
#include "core/cycle.hpp"
#include "core/result.hpp"
#include "protocol/robot_frames.hpp"

namespace vgr::daemon {

struct JournalOptions {
  std::uint64_t maxBytes = 100ull << 20;  // bytes, >= 64 KiB: rotate when the file reaches it
  int keepFiles = 9;                      // [1, 1000]: rotated files kept (<path>.1 .. .N)
  int syncMs = 1000;                      // ms, [-1, 3600000]: fdatasync policy (above)
};

// What appending cost so far (any thread).
struct JournalStats {
  std::uint64_t records = 0;
  std::uint64_t writeMicros = 0;  // summed time in write() (wall, µs)
  std::uint64_t syncs = 0;
  std::uint64_t syncMicros = 0;   // summed time in fdatasync() (wall, µs)
  std::uint64_t rotations = 0;
};

// A robot endpoint whose replies differ from the journal's base-frame poses (offset mode or
// a user frame): each OK line then says what it gets for every part ("robots", docs/journal.md).
struct JournalRobot {
  std::string name;
  protocol::Dialect dialect = protocol::Dialect::Ur;
  protocol::RobotFrame frame;
  std::string frameName;
};
// The cell's robots in offset mode or with a user frame, in config order.
std::vector<JournalRobot> journalRobots(const config::CellConfig& cell);

class Journal {
 public:
  Journal() = default;
  ~Journal();
  Journal(const Journal&) = delete;
  Journal& operator=(const Journal&) = delete;

  // Creates the parent folder if needed, repairs a torn last line (see above); error
  // names the path.
  Result<void> open(const std::string& path, JournalOptions options = {});
  // Before the cycle thread starts: the robots each line reports on (journalRobots()).
  void setRobots(std::vector<JournalRobot> robots) { robots_ = std::move(robots); }
  void append(const CycleResult& r);
  // "trigger" is the cycle's TriggerSource ("modbus", "robot", "operator"); `robots` adds
  // what each of them receives for every part.
  static std::string toJson(const CycleResult& r, const std::vector<JournalRobot>& robots = {});

  // The `cycle` of the last complete line found by open() (0: none), then of the last
  // record appended.
  std::uint32_t lastCycleId() const { return lastCycleId_.load(); }
  // Records that could not be written since open().
  std::uint64_t writeErrors() const { return writeErrors_.load(); }
  JournalStats stats() const;

 private:
  void rotate();
  int fd_ = -1;
  std::string path_;
  JournalOptions options_;
  std::uint64_t size_ = 0;  // bytes in the current file (cycle thread)
  std::chrono::steady_clock::time_point lastSync_{};
  std::atomic<std::uint64_t> records_{0}, writeMicros_{0}, syncs_{0}, syncMicros_{0}, rotations_{0};
  std::vector<JournalRobot> robots_;
  std::atomic<std::uint32_t> lastCycleId_{0};
  std::atomic<std::uint64_t> writeErrors_{0};
  std::uint64_t burst_ = 0;  // failures since the last successful write (cycle thread)
};

}  // namespace vgr::daemon
