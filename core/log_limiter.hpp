// Rate limit for log lines that an outside party can cause at will (a connection storm, a
// reset storm, a client flooding bad frames): at most `burst` lines per `window` get
// through; the rest are counted, and the next line that gets through says how many were
// held back. Counting instead of logging keeps a storm of 12,000 connections from writing
// megabytes of log (issue 19, item 8) while the first lines of every burst still show.
//
// Not thread-safe: one limiter per owner thread (a server's I/O or Modbus thread).
#pragma once

#include <chrono>
#include <cstdint>
#include <string>
#include <string_view>
#include <utility>

#include "core/log.hpp"

namespace vgr::log {

class LogLimiter {
 public:
  using Clock = std::chrono::steady_clock;

  LogLimiter(int burst, Clock::duration window) : burst_(burst), window_(window) {}

  // True when this line may be written. `heldBack` is then set to the number of lines
  // held back since the last one that got through (append "(N more not logged)" when > 0).
  bool allow(std::uint64_t& heldBack, Clock::time_point now = Clock::now()) {
    if (now - windowStart_ >= window_) {
      windowStart_ = now;
      inWindow_ = 0;
    }
    if (inWindow_ >= burst_) {
      ++pending_;
      ++heldBackTotal_;
      return false;
    }
    ++inWindow_;
    heldBack = pending_;
    pending_ = 0;
    return true;
  }

  // Lines held back since construction.
  std::uint64_t heldBackTotal() const { return heldBackTotal_; }

 private:
  int burst_;
  Clock::duration window_;
  Clock::time_point windowStart_{};
  int inWindow_ = 0;
  std::uint64_t pending_ = 0;
  std::uint64_t heldBackTotal_ = 0;
};

// One event line through `limiter` under `sub` at info (or warn when `warning`), with
// "(N more <what> not logged)" appended to the first line after a held-back run; false when
// this line was held back (the caller counts those where it exposes them).
template <class... Args>
bool limitedLog(LogLimiter& limiter, std::string_view sub, std::string_view what, bool warning,
                fmt::format_string<Args...> f, Args&&... args) {
  std::uint64_t heldBack = 0;
  if (!limiter.allow(heldBack)) return false;
  std::string line = fmt::format(f, std::forward<Args>(args)...);
  if (heldBack > 0) line += fmt::format(" ({} more {} not logged)", heldBack, what);
  if (warning)
    warn(sub, "{}", line);
  else
    info(sub, "{}", line);
  return true;
}

}  // namespace vgr::log
