// A datagram socket standing in for systemd's NOTIFY_SOCKET (`vgr demo`, `vgr soak`): the
// READY=1, WATCHDOG=1 and STOPPING=1 notifications of a vgrd started with
// NOTIFY_SOCKET=<path> arrive here. One owner thread.
#pragma once

#include <chrono>
#include <string>

#include "core/child_process.hpp"

namespace vgr::tools {

class NotifyListener {
 public:
  explicit NotifyListener(std::string path);  // unlinks and binds `path`
  ~NotifyListener();                          // closes and unlinks it
  NotifyListener(const NotifyListener&) = delete;
  NotifyListener& operator=(const NotifyListener&) = delete;

  bool ok() const { return fd_ >= 0; }
  const std::string& path() const { return path_; }
  // True when a datagram containing `what` arrives within `timeout`; false at once when
  // `child` is no longer running.
  bool waitFor(const std::string& what, std::chrono::milliseconds timeout, ChildProcess& child);

 private:
  std::string path_;
  int fd_ = -1;
};

}  // namespace vgr::tools
