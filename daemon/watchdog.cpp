#include "daemon/watchdog.hpp"

#include <algorithm>

namespace vgr::daemon {

void Watchdog::watch(std::string name, const Heartbeat& heartbeat, std::chrono::milliseconds stallLimit) {
  threads_.push_back({std::move(name), &heartbeat, stallLimit});
}

std::vector<Watchdog::Stall> Watchdog::stalled(Clock::time_point now) const {
  std::vector<Stall> out;
  for (const auto& t : threads_) {
    const auto since = t.heartbeat->sinceLastBeat(now);
    if (!since || *since <= t.limit) continue;
    out.push_back({t.name, std::chrono::duration_cast<std::chrono::milliseconds>(*since), t.limit});
  }
  std::sort(out.begin(), out.end(), [](const Stall& a, const Stall& b) { return a.silentFor > b.silentFor; });
  return out;
}

std::vector<std::pair<std::string, std::chrono::milliseconds>> Watchdog::silences(Clock::time_point now) const {
  std::vector<std::pair<std::string, std::chrono::milliseconds>> out;
  for (const auto& t : threads_)
    if (const auto since = t.heartbeat->sinceLastBeat(now))
      out.emplace_back(t.name, std::chrono::duration_cast<std::chrono::milliseconds>(*since));
  return out;
}

}  // namespace vgr::daemon
