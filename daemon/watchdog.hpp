// vgrd's systemd watchdog that means something (docs/plant.md, "Watchdog"): WATCHDOG=1 is
// sent only while every long-lived thread makes progress. Each thread (cycle, camera,
// Modbus server, Modbus client) owns a vgr::Heartbeat that it beats at every turn of its
// loop; the I/O thread, which sends the pings, proves its own life by sending them. A thread
// whose last beat is older than its stall limit is stalled: the pings stop, systemd kills
// vgrd WatchdogSec later and restarts it (Restart=on-failure), and the log says which
// thread stalled and for how long before that happens.
//
// This class is the decision alone (no clock, no systemd, no threads of its own): the I/O
// thread calls check() on a timer and acts on the answer. I/O thread only.
#pragma once

#include <chrono>
#include <string>
#include <utility>
#include <vector>

#include "core/heartbeat.hpp"

namespace vgr::daemon {

class Watchdog {
 public:
  using Clock = Heartbeat::Clock;

  // Registers a thread: `name` for the log ("cycle", "camera", ...), its heartbeat (borrowed;
  // must outlive this object), and how long it may go without a beat. The limit must exceed
  // the longest bounded wait or blocking call between two beats of that thread.
  void watch(std::string name, const Heartbeat& heartbeat, std::chrono::milliseconds stallLimit);

  struct Stall {
    std::string thread;
    std::chrono::milliseconds silentFor;
    std::chrono::milliseconds limit;
  };
  // The threads whose last beat is older than their limit at `now`, worst first. A thread
  // that has never beaten is not stalled yet (it has not started).
  std::vector<Stall> stalled(Clock::time_point now) const;

  // Every started thread's time since its last beat at `now`, in the order watched (for the
  // pause report, daemon/pause_probe.hpp).
  std::vector<std::pair<std::string, std::chrono::milliseconds>> silences(Clock::time_point now) const;

  std::size_t size() const { return threads_.size(); }

 private:
  struct Watched {
    std::string name;
    const Heartbeat* heartbeat;
    std::chrono::milliseconds limit;
  };
  std::vector<Watched> threads_;
};

// The stall limits live with the threads (each is the longest legitimate gap between two
// beats of that thread plus a margin): CycleRunner::stallLimit(), CameraWorker::kStallLimit,
// PlcLink::stallLimit(); docs/plant.md lists them.

}  // namespace vgr::daemon
