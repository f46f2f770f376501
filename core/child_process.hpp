// Child processes for `vgr demo`, the benches and the tests: spawn with arguments, read
// their stdout line by line, stop them with SIGTERM (then SIGKILL after a grace period).
// POSIX only (posix_spawn); one owner per object, not thread-safe.
#pragma once

#include <sys/types.h>

#include <chrono>
#include <optional>
#include <string>
#include <vector>

namespace vgr {

class ChildProcess {
 public:
  ChildProcess() = default;
  ~ChildProcess();  // stops the child if still running
  ChildProcess(ChildProcess&&) noexcept;
  ChildProcess& operator=(ChildProcess&&) noexcept;
  ChildProcess(const ChildProcess&) = delete;
  ChildProcess& operator=(const ChildProcess&) = delete;

  // argv[0] is the executable path. stdout is captured (readLine); stderr goes to
  // `stderrPath` when given (appended), else it is inherited.
  static std::optional<ChildProcess> spawn(const std::vector<std::string>& argv, const std::string& stderrPath = "");

  // Next stdout line (without '\n') within `timeout`; empty optional on timeout or EOF.
  std::optional<std::string> readLine(std::chrono::milliseconds timeout);
  // Reads lines until one contains `needle`.
  bool waitForLine(const std::string& needle, std::chrono::milliseconds timeout);

  bool running();
  // SIGTERM, wait up to `grace`, then SIGKILL. Returns the exit status (or -signal).
  int stop(std::chrono::milliseconds grace = std::chrono::milliseconds(3000));
  void kill9();
  int wait(std::chrono::milliseconds timeout);  // -1000 if still running
  pid_t pid() const { return pid_; }

 private:
  pid_t pid_ = -1;
  int outFd_ = -1;
  std::string buffer_;
  std::optional<int> status_;
};

}  // namespace vgr
