#include "daemon/image_archive.hpp"

#include <sys/resource.h>
#include <sys/syscall.h>
#include <unistd.h>

#include <algorithm>
#include <cerrno>
#include <cstdio>
#include <cstring>
#include <ctime>
#include <filesystem>
#include <map>
#include <regex>

#include <fcntl.h>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/log.hpp"
#include "daemon/journal.hpp"

namespace vgr::daemon {

namespace fs = std::filesystem;

namespace {

constexpr int kPngCompression = 1;  // zlib level: fastest; PNG stays lossless at every level
// The writer yields the CPU to the cycle thread when both want it (CFS weight 335 against
// 1024); more (nice 10: 110) starved it on a loaded machine: frames waited seconds.
constexpr int kWriterNice = 5;

// Writes `bytes` to path + ".tmp", then renames it to path: a file under its final name is
// always complete. Error text on failure ("" on success).
std::string writeAtomically(const std::string& path, const void* data, std::size_t size) {
  const std::string tmp = path + ".tmp";
  const int fd = ::open(tmp.c_str(), O_WRONLY | O_CREAT | O_TRUNC | O_CLOEXEC, 0644);
  if (fd < 0) return tmp + ": " + std::strerror(errno);
  const auto* p = static_cast<const char*>(data);
  std::size_t left = size;
  while (left > 0) {
    const auto n = ::write(fd, p, left);
    if (n < 0 && errno == EINTR) continue;
    if (n <= 0) {
      const int err = n < 0 ? errno : ENOSPC;
      ::close(fd);
      ::unlink(tmp.c_str());
      return tmp + ": " + std::strerror(err);
    }
    p += n;
    left -= static_cast<std::size_t>(n);
  }
  if (::close(fd) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return tmp + ": " + std::strerror(err);
  }
  if (::rename(tmp.c_str(), path.c_str()) != 0) {
    const int err = errno;
    ::unlink(tmp.c_str());
    return path + ": " + std::strerror(err);
  }
  return "";
}

std::uint64_t fileBytes(const fs::path& p) {
  std::error_code ec;
  const auto n = fs::file_size(p, ec);
  return ec ? 0 : static_cast<std::uint64_t>(n);
}

}  // namespace

std::string archiveStem(std::uint32_t cycleId, std::chrono::system_clock::time_point t) {
  const auto ms = std::chrono::duration_cast<std::chrono::milliseconds>(t.time_since_epoch()).count();
  const std::time_t secs = static_cast<std::time_t>(ms / 1000);
  std::tm tm{};
  gmtime_r(&secs, &tm);
  return fmt::format("{:04}{:02}{:02}-{:02}{:02}{:02}.{:03}-c{}", tm.tm_year + 1900, tm.tm_mon + 1, tm.tm_mday, tm.tm_hour,
                     tm.tm_min, tm.tm_sec, static_cast<int>(ms % 1000), cycleId);
}

std::string archiveDir(const config::CellConfig& cell) {
  if (!cell.archive.dir.empty()) return cell.archive.dir;
  return (fs::path(cell.journalPath).parent_path() / "archive").string();
}

bool isArchiveName(const std::string& name, const std::string& ext) {
  static const std::regex stem(R"(\d{8}-\d{6}\.\d{3}-c\d{1,7})");
  if (ext.empty()) return std::regex_match(name, stem);
  if (name.size() <= ext.size() || name.compare(name.size() - ext.size(), ext.size(), ext) != 0) return false;
  return std::regex_match(name.substr(0, name.size() - ext.size()), stem);
}

struct ImageArchive::Slot {
  cv::Mat gray;        // CV_8UC1, reused
  CycleResult result;  // reused (its parts vector keeps its capacity)
  std::vector<uchar> png;  // encode buffer, reused (writer thread)
};

ImageArchive::ImageArchive(const config::ArchiveConfig& config, std::string dir) : cfg_(config), dir_(std::move(dir)) {
  for (int i = 0; i < cfg_.queue; ++i) {
    slots_.push_back(std::make_unique<Slot>());
    free_.push_back(slots_.back().get());
  }
}

ImageArchive::~ImageArchive() { stop(); }

Result<void> ImageArchive::start() {
  std::error_code ec;
  fs::create_directories(dir_, ec);
  if (ec || !fs::is_directory(dir_)) return fail(Status::BadArgument, "archive " + dir_ + ": cannot create it" + (ec ? ": " + ec.message() : ""));
  if (::access(dir_.c_str(), W_OK) != 0) return fail(Status::BadArgument, "archive " + dir_ + ": not writable: " + std::strerror(errno));
  // Index what is there (a restart keeps the archive), oldest first by name = by time.
  std::map<std::string, std::uint64_t> stems;
  for (const auto& e : fs::directory_iterator(dir_, ec)) {
    if (!e.is_regular_file()) continue;
    const std::string name = e.path().filename().string();
    if (name.size() > 4 && name.compare(name.size() - 4, 4, ".tmp") == 0) {
      fs::remove(e.path(), ec);  // a write cut short by a crash
      continue;
    }
    for (const char* ext : {".png", ".json"})
      if (isArchiveName(name, ext)) stems[name.substr(0, name.size() - std::strlen(ext))] += fileBytes(e.path());
  }
  {
    std::lock_guard lock(mutex_);
    std::uint64_t total = 0;
    for (const auto& [stem, bytes] : stems) {
      index_.push_back({stem, bytes});
      total += bytes;
    }
    bytes_ = total;
    applyQuota(0);
  }
  log::info("archive", "{}: {} frame(s), {:.1f} MB of {:.1f} MB; keeping failed cycles{}", dir_, index_.size(),
            bytes_.load() / 1e6, cfg_.quotaBytes / 1e6,
            cfg_.everyNthGood > 0 ? fmt::format(" and every {}. good one", cfg_.everyNthGood) : std::string(" only"));
  stopping_ = false;
  thread_ = std::thread([this] { run(); });
  return {};
}

void ImageArchive::stop() {
  {
    std::lock_guard lock(mutex_);
    stopping_ = true;
  }
  cv_.notify_all();
  if (thread_.joinable()) thread_.join();
}

bool ImageArchive::offer(const CycleResult& r, const cv::Mat& gray) {
  if (gray.empty() || gray.type() != CV_8UC1) return false;
  bool keep = r.status != Status::Ok;
  if (!keep && cfg_.everyNthGood > 0) keep = ++okSeen_ % static_cast<std::uint64_t>(cfg_.everyNthGood) == 0;
  if (!keep) return false;
  Slot* slot = nullptr;
  {
    std::lock_guard lock(mutex_);
    if (stopping_ || free_.empty()) {
      ++dropped_;
      return false;
    }
    slot = free_.back();
    free_.pop_back();
  }
  gray.copyTo(slot->gray);  // no allocation once the slot has held a frame of this size
  slot->result = r;
  slot->result.archived = true;
  {
    std::lock_guard lock(mutex_);
    pending_.push_back(slot);
  }
  cv_.notify_one();
  return true;
}

void ImageArchive::run() {
  // Linux: setpriority(PRIO_PROCESS, tid) sets one thread's nice value.
  if (::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), kWriterNice) != 0)
    log::debug("archive", "cannot lower the writer's priority: {}", std::strerror(errno));
  for (;;) {
    Slot* slot = nullptr;
    {
      std::unique_lock lock(mutex_);
      cv_.wait(lock, [this] { return stopping_ || !pending_.empty(); });
      if (pending_.empty()) return;  // stopping, all written
      slot = pending_.front();
      pending_.pop_front();
      writing_ = true;
    }
    write(*slot);
    std::lock_guard lock(mutex_);
    writing_ = false;
    free_.push_back(slot);
  }
}

void ImageArchive::write(Slot& slot) {
  const std::string stem = archiveStem(slot.result.cycleId, slot.result.triggerTime);
  const fs::path base = fs::path(dir_) / stem;
  std::string err;
  try {
    if (!cv::imencode(".png", slot.gray, slot.png, {cv::IMWRITE_PNG_COMPRESSION, kPngCompression})) err = "PNG encoding failed";
  } catch (const cv::Exception& e) {
    err = std::string("PNG encoding failed: ") + e.what();
  }
  const std::string line = Journal::toJson(slot.result) + "\n";
  const std::uint64_t bytes = slot.png.size() + line.size();
  if (err.empty() && bytes > cfg_.quotaBytes)
    err = fmt::format("the frame ({} bytes) is larger than the whole quota ({} bytes)", bytes, cfg_.quotaBytes);
  if (err.empty()) {
    // Room first (oldest out), then the new files: the folder never holds more than the quota.
    std::lock_guard lock(mutex_);
    applyQuota(bytes);
  }
  if (err.empty()) err = writeAtomically(base.string() + ".png", slot.png.data(), slot.png.size());
  if (err.empty()) {
    err = writeAtomically(base.string() + ".json", line.data(), line.size());
    if (!err.empty()) ::unlink((base.string() + ".png").c_str());
  }
  if (!err.empty()) {
    ++writeErrors_;
    if (errorBurst_++ == 0)
      log::error("archive", "cycle {}: {}; further failures are counted (vgr_archive_write_errors_total)", slot.result.cycleId, err);
    return;
  }
  if (errorBurst_ > 0) log::info("archive", "{}: writing again after {} frame(s) could not be written", dir_, errorBurst_);
  errorBurst_ = 0;
  std::lock_guard lock(mutex_);
  index_.push_back({stem, bytes});
  bytes_ += bytes;
  ++written_;
}

void ImageArchive::applyQuota(std::uint64_t reserve) {
  std::error_code ec;
  while (!index_.empty() && bytes_.load() + reserve > cfg_.quotaBytes) {
    const ArchivedFrame& oldest = index_.front();
    for (const char* ext : {".png", ".json"}) fs::remove(fs::path(dir_) / (oldest.stem + ext), ec);
    bytes_ -= std::min(bytes_.load(), oldest.bytes);
    ++deleted_;
    index_.pop_front();
  }
}

ArchiveCounters ImageArchive::counters() const {
  ArchiveCounters c;
  c.written = written_.load();
  c.dropped = dropped_.load();
  c.deleted = deleted_.load();
  c.writeErrors = writeErrors_.load();
  c.bytes = bytes_.load();
  c.quotaBytes = cfg_.quotaBytes;
  std::lock_guard lock(mutex_);
  c.files = index_.size();
  c.queued = pending_.size() + (writing_ ? 1 : 0);
  return c;
}

std::vector<ArchivedFrame> ImageArchive::list(std::size_t limit) const {
  std::lock_guard lock(mutex_);
  std::vector<ArchivedFrame> out;
  for (auto it = index_.rbegin(); it != index_.rend() && out.size() < limit; ++it) out.push_back(*it);
  return out;
}

}  // namespace vgr::daemon
