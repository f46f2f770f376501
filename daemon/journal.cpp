#include "daemon/journal.hpp"

#include <algorithm>
#include <cerrno>
#include <chrono>
#include <cmath>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <vector>

#include <fcntl.h>
#include <unistd.h>

#include <nlohmann/json.hpp>

#include "core/log.hpp"
#include "daemon/image_archive.hpp"

namespace vgr::daemon {

namespace {

namespace fs = std::filesystem;

constexpr std::uintmax_t kTailBytes = 64 * 1024;  // read back to find the last line

// The cycle id of the last parsable line in `tail` (complete lines only), 0 if none.
std::uint32_t lastCycleIn(const std::string& tail) {
  std::size_t end = tail.size();
  while (end > 0) {
    const std::size_t nl = tail.rfind('\n', end - 1);
    const std::size_t begin = nl == std::string::npos ? 0 : nl + 1;
    if (end > begin) {
      const auto j = nlohmann::json::parse(tail.substr(begin, end - begin), nullptr, false);
      if (j.is_object() && j.contains("cycle") && j["cycle"].is_number_unsigned()) return j["cycle"].get<std::uint32_t>();
    }
    if (nl == std::string::npos) break;
    end = nl;
  }
  return 0;
}

// The cycle id of the last complete line of the file at `path` (0: none, or unreadable).
std::uint32_t lastCycleOfFile(const std::string& path) {
  std::error_code ec;
  const std::uintmax_t size = fs::file_size(path, ec);
  if (ec || size == 0) return 0;
  const std::uintmax_t from = size > kTailBytes ? size - kTailBytes : 0;
  std::string tail(static_cast<std::size_t>(size - from), '\0');
  std::ifstream in(path, std::ios::binary);
  in.seekg(static_cast<std::streamoff>(from));
  in.read(tail.data(), static_cast<std::streamsize>(tail.size()));
  if (!in) return 0;
  tail.resize(tail.rfind('\n') == std::string::npos ? 0 : tail.rfind('\n') + 1);
  return lastCycleIn(tail);
}

std::uint64_t microsSince(std::chrono::steady_clock::time_point t0) {
  return static_cast<std::uint64_t>(
      std::chrono::duration_cast<std::chrono::microseconds>(std::chrono::steady_clock::now() - t0).count());
}

}  // namespace

std::vector<JournalRobot> journalRobots(const config::CellConfig& cell) {
  std::vector<JournalRobot> out;
  for (const auto& r : cell.robots)
    if (r.delivery == config::Delivery::Offset || r.frameName != "base")
      out.push_back({r.name, r.dialect, protocol::RobotFrame{r.delivery, r.baseFromUser}, r.frameName});
  return out;
}

Journal::~Journal() {
  if (fd_ < 0) return;
  if (options_.syncMs >= 0) ::fdatasync(fd_);
  ::close(fd_);
}

Result<void> Journal::open(const std::string& path, JournalOptions options) {
  if (options.maxBytes < (64u << 10) || options.keepFiles < 1 || options.keepFiles > 1000 || options.syncMs < -1)
    return fail(Status::BadArgument, "journal " + path + ": options out of range");
  options_ = options;
  std::error_code ec;
  const auto parent = fs::path(path).parent_path();
  if (!parent.empty()) fs::create_directories(parent, ec);
  path_ = path;
  // A torn last line: set it apart, keep every complete line.
  if (fs::is_regular_file(path, ec) && fs::file_size(path, ec) > 0 && !ec) {
    const std::uintmax_t size = fs::file_size(path, ec);
    const std::uintmax_t from = size > kTailBytes ? size - kTailBytes : 0;
    std::string tail(static_cast<std::size_t>(size - from), '\0');
    {
      std::ifstream in(path, std::ios::binary);
      in.seekg(static_cast<std::streamoff>(from));
      in.read(tail.data(), static_cast<std::streamsize>(tail.size()));
      if (!in) return fail(Status::BadArgument, "journal " + path + ": cannot read it back: " + std::strerror(errno));
    }
    if (tail.back() != '\n') {
      const std::size_t nl = tail.rfind('\n');
      const std::size_t keep = nl == std::string::npos ? 0 : nl + 1;
      if (nl == std::string::npos && from > 0) {
        return fail(Status::BadArgument, "journal " + path + ": last 64 KiB hold no line end; not repaired");
      }
      const auto now = std::chrono::duration_cast<std::chrono::seconds>(std::chrono::system_clock::now().time_since_epoch());
      const std::string tornPath = path + ".torn-" + std::to_string(now.count());
      std::ofstream(tornPath, std::ios::binary | std::ios::app).write(tail.data() + keep, static_cast<std::streamsize>(tail.size() - keep));
      fs::resize_file(path, from + keep, ec);
      if (ec) return fail(Status::BadArgument, "journal " + path + ": cannot cut its torn last line: " + ec.message());
      log::warn("journal", "{}: last line was torn ({} bytes without a line end, e.g. after kill -9 or power loss): "
                "set apart in {}; every complete line kept", path, tail.size() - keep, tornPath);
      tail.resize(keep);
    }
    lastCycleId_ = lastCycleIn(tail);
  }
  // Just rotated (or cut to nothing): the last record is in the newest rotated file.
  if (lastCycleId_ == 0) lastCycleId_ = lastCycleOfFile(path + ".1");
  fd_ = ::open(path.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) return fail(Status::BadArgument, "journal " + path + ": " + std::strerror(errno));
  const auto size = fs::file_size(path, ec);
  size_ = ec ? 0 : static_cast<std::uint64_t>(size);
  lastSync_ = std::chrono::steady_clock::now();
  return {};
}

JournalStats Journal::stats() const {
  return {records_.load(), writeMicros_.load(), syncs_.load(), syncMicros_.load(), rotations_.load()};
}

void Journal::rotate() {
  // Everything written so far reaches the disk before the file changes name.
  if (options_.syncMs >= 0) ::fdatasync(fd_);
  ::close(fd_);
  fd_ = -1;
  std::error_code ec;
  const auto numbered = [&](int i) { return path_ + "." + std::to_string(i); };
  fs::remove(numbered(options_.keepFiles), ec);
  for (int i = options_.keepFiles - 1; i >= 1; --i) {
    if (fs::exists(numbered(i), ec)) fs::rename(numbered(i), numbered(i + 1), ec);
  }
  fs::rename(path_, numbered(1), ec);
  const bool renamed = !ec;
  if (!renamed)
    log::error("journal", "{}: cannot rotate it to {}: {}; appending on (next try after another {} bytes)", path_,
               numbered(1), ec.message(), options_.maxBytes);
  fd_ = ::open(path_.c_str(), O_WRONLY | O_APPEND | O_CREAT | O_CLOEXEC, 0644);
  if (fd_ < 0) {
    log::error("journal", "{}: cannot open it after rotating: {}", path_, std::strerror(errno));
    return;
  }
  if (!renamed) {
    size_ = 0;
    return;
  }
  const auto size = fs::file_size(path_, ec);
  size_ = ec ? 0 : static_cast<std::uint64_t>(size);
  ++rotations_;
  log::info("journal", "{}: reached {} bytes, rotated to {} (keeping {} files)", path_, options_.maxBytes, numbered(1),
            options_.keepFiles);
}

namespace {
// + 0.0 turns -0.0 into 0.0: no "-0" in the journal.
double round3(double v) { return std::round(v * 1000.0) / 1000.0 + 0.0; }
}  // namespace

namespace {

nlohmann::json partJson(const PartResult& p) {
  const auto e = toEulerZyxDeg(p.pose);
  const auto o = toEulerZyxDeg(p.offset);
  return {{"x_mm", round3(p.pose.x)},   {"y_mm", round3(p.pose.y)},     {"z_mm", round3(p.pose.z)},
          {"rz_deg", round3(e.rz)},     {"ry_deg", round3(e.ry)},       {"rx_deg", round3(e.rx)},
          {"dx_mm", round3(p.offset.x)}, {"dy_mm", round3(p.offset.y)}, {"dz_mm", round3(p.offset.z)},
          {"drz_deg", round3(o.rz)},    {"dry_deg", round3(o.ry)},      {"drx_deg", round3(o.rx)},
          {"u_px", round3(p.uPx)},      {"v_px", round3(p.vPx)},        {"angle_img_deg", round3(p.angleImgDeg)},
          {"scale", std::round(p.scale * 1e5) / 1e5}, {"score", round3(p.score)}, {"label", p.label},
          {"confidence", round3(p.confidence)}};
}

}  // namespace

std::string Journal::toJson(const CycleResult& r, const std::vector<JournalRobot>& robots) {
  nlohmann::json j;
  j["cycle"] = r.cycleId;
  j["time"] = std::chrono::duration_cast<std::chrono::milliseconds>(r.triggerTime.time_since_epoch()).count() / 1000.0;
  j["trigger"] = triggerSourceName(r.trigger);
  j["job"] = r.jobId;
  j["status"] = statusCode(r.status);
  j["status_name"] = std::string(statusName(r.status));
  j["frame_id"] = r.frameId;
  j["grab_ms"] = round3(r.grabMs);
  j["locate_ms"] = round3(r.locateMs);
  j["total_ms"] = round3(r.totalMs);
  nlohmann::json parts = nlohmann::json::array();
  for (const auto& p : r.parts) parts.push_back(partJson(p));
  j["parts"] = std::move(parts);
  if (r.flange) {  // eye-in-hand: where the robot said its flange was for this image
    const auto e = toEulerZyxDeg(*r.flange);
    j["flange"] = {{"x_mm", round3(r.flange->x)}, {"y_mm", round3(r.flange->y)}, {"z_mm", round3(r.flange->z)},
                   {"rz_deg", round3(e.rz)}, {"ry_deg", round3(e.ry)}, {"rx_deg", round3(e.rx)}};
  }
  if (!r.rejected.empty()) {
    nlohmann::json rejected = nlohmann::json::array();
    for (const auto& x : r.rejected) {
      nlohmann::json p = partJson(x.part);
      p["why"] = x.why;
      rejected.push_back(std::move(p));
    }
    j["rejected"] = std::move(rejected);
  }
  if (!robots.empty() && !r.parts.empty()) {
    // What each robot in offset mode or a user frame gets for each part (mm, Z-Y-X deg;
    // its dialect converts units), in the order of `parts`.
    nlohmann::json out = nlohmann::json::object();
    for (const auto& robot : robots) {
      nlohmann::json poses = nlohmann::json::array();
      for (const auto& p : r.parts) {
        const Pose d = protocol::deliveredPose(robot.dialect, robot.frame, r.reference, p.pose);
        const auto e = toEulerZyxDeg(d);
        poses.push_back({round3(d.x), round3(d.y), round3(d.z), round3(e.rz), round3(e.ry), round3(e.rx)});
      }
      out[robot.name] = {{"deliver", std::string(protocol::deliveryName(robot.frame.delivery))},
                         {"frame", robot.frameName},
                         {"poses", std::move(poses)}};
    }
    j["robots"] = std::move(out);
  }
  if (r.driftMonitored) {
    j["drift_mm"] = std::isfinite(r.driftMm) ? nlohmann::json(round3(r.driftMm)) : nlohmann::json(nullptr);
    j["drift_alarm"] = r.driftAlarm;
  }
  if (r.archived) j["archive"] = archiveStem(r.cycleId, r.triggerTime) + ".png";
  return j.dump();
}

void Journal::append(const CycleResult& r) {
  if (fd_ < 0) return;
  const std::string line = toJson(r, robots_) + "\n";
  const auto t0 = std::chrono::steady_clock::now();
  const auto n = ::write(fd_, line.data(), line.size());
  writeMicros_ += microsSince(t0);
  if (n > 0) size_ += static_cast<std::uint64_t>(n);
  if (n == std::ssize(line)) {
    ++records_;
    lastCycleId_ = r.cycleId;
    if (burst_ > 0) log::info("journal", "{}: writing again after {} records could not be written", path_, burst_);
    burst_ = 0;
    const auto now = std::chrono::steady_clock::now();
    if (options_.syncMs >= 0 && now - lastSync_ >= std::chrono::milliseconds(options_.syncMs)) {
      ::fdatasync(fd_);
      lastSync_ = std::chrono::steady_clock::now();
      syncMicros_ += static_cast<std::uint64_t>(
          std::chrono::duration_cast<std::chrono::microseconds>(lastSync_ - now).count());
      ++syncs_;
    }
    if (size_ >= options_.maxBytes) rotate();
    return;
  }
  const int err = n < 0 ? errno : ENOSPC;
  if (n > 0) {  // a short write: end it so the next record starts on a line of its own
    [[maybe_unused]] const auto ended = ::write(fd_, "\n", 1);
  }
  ++writeErrors_;
  if (burst_++ == 0) {
    log::error("journal", "{}: cannot write cycle {}: {}; further failures are counted (60 s summary) until a "
               "write succeeds", path_, r.cycleId, std::strerror(err));
  }
}

}  // namespace vgr::daemon
