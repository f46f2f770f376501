// A long-lived thread's proof of life, read by vgrd's systemd watchdog (daemon/watchdog.hpp).
//
// The owning thread calls beat() whenever it makes progress: at every turn of its loop,
// including the bounded waits of an idle loop (so an idle thread stays alive) and between
// blocking calls whose duration is bounded. Any thread may read sinceLastBeat(). Lock-free:
// beat() is one relaxed atomic store of the steady clock, cheap enough for every loop turn.
// A Heartbeat that never beat reports "never" (nullopt), which the watchdog treats as not
// yet started rather than stalled.
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <optional>

namespace vgr {

class Heartbeat {
 public:
  using Clock = std::chrono::steady_clock;

  // Owning thread.
  void beat() noexcept { last_.store(Clock::now().time_since_epoch().count(), std::memory_order_relaxed); }

  // Any thread: time since the last beat at `now`, nullopt before the first beat.
  std::optional<Clock::duration> sinceLastBeat(Clock::time_point now) const noexcept {
    const std::int64_t t = last_.load(std::memory_order_relaxed);
    if (t == kNever) return std::nullopt;
    return now - Clock::time_point(Clock::duration(t));
  }

 private:
  static constexpr std::int64_t kNever = INT64_MIN;
  std::atomic<std::int64_t> last_{kNever};
};

}  // namespace vgr

namespace vgr {

// Names the calling thread for `top -H`, `ps -L`, gdb and /proc/<pid>/task/<tid>/comm
// (at most 15 characters: "vgr-cycle", "vgr-camera", "vgr-modbus", ...). Best effort.
void nameThisThread(const char* name) noexcept;

}  // namespace vgr
