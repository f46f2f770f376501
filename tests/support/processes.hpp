// Background programs for the tests: ChildProcess (spawn with arguments, stdout read line by
// line, stderr to a log file, stop by SIGTERM then SIGKILL after a grace period), the camera
// emulator started and waited for, and a NOTIFY_SOCKET listener that receives sd_notify
// datagrams (READY=1, STOPPING=1) from a child as systemd would. All blocking, test thread.
#pragma once

#include <chrono>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "core/child_process.hpp"

namespace vgr::test {

// The one implementation (shared with `vgr demo`); only this header names where it lives.
using ChildProcess = vgr::ChildProcess;

// vgr-sim-camera with `args`, stderr appended to `logPath` (inherited when empty), waited for
// until it prints its "ready" line. Null, with a test failure recorded, when it did not come
// up in time (typically: GigE port 3956 busy).
std::unique_ptr<ChildProcess> startEmulator(const std::vector<std::string>& args, const std::string& logPath = "",
                                            std::chrono::milliseconds timeout = std::chrono::milliseconds(5000));

// A datagram socket at `path` (unlinked first and on destruction); pass path() as the child's
// NOTIFY_SOCKET (see spawnWithNotify).
class NotifySocket {
 public:
  explicit NotifySocket(std::string path);
  ~NotifySocket();
  NotifySocket(const NotifySocket&) = delete;
  NotifySocket& operator=(const NotifySocket&) = delete;

  bool ok() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }
  // True when a datagram containing `what` arrives within `timeout`.
  bool waitFor(const std::string& what, std::chrono::milliseconds timeout);
  // How many datagrams containing `what` arrive during `window` (reads for all of it).
  int countFor(const std::string& what, std::chrono::milliseconds window);

 private:
  std::string path_;
  int fd_ = -1;
};

// Scheduling for latency measurements on this shared machine: at load ~20 on two cores a
// woken thread waits 5-70 ms behind other people's compilers, even at nice -10, so both an
// idle and an attacked p99 say nothing about the server. The measured side (the server's
// threads, its good client) runs SCHED_FIFO priority 10 while it is measured, as if it had
// its IPC to itself (it sleeps in poll/epoll between requests; what an attack makes it do is
// bounded by its token buckets); an attacker runs at nice +10 (a real attacker is another
// machine, its CPU use is not what a test measures). Root only; false when the kernel
// refused. setThreadNormal() returns the calling thread to SCHED_OTHER, nice 0.
bool setThreadNice(int nice);
bool setThreadRealtime();
bool setProcessRealtime(pid_t pid);  // every thread of process `pid`
void setThreadNormal();

// ChildProcess::spawn with NOTIFY_SOCKET=notify.path() in the child's environment only.
std::optional<ChildProcess> spawnWithNotify(const std::vector<std::string>& argv, const std::string& logPath,
                                            const NotifySocket& notify);

}  // namespace vgr::test
