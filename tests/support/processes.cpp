#include "tests/support/processes.hpp"

#include <sched.h>
#include <sys/resource.h>
#include <sys/socket.h>
#include <sys/syscall.h>
#include <sys/un.h>
#include <unistd.h>

#include <filesystem>

#include <cstdio>
#include <cstdlib>
#include <utility>

#include <gtest/gtest.h>

#include "tests/support/command.hpp"

namespace vgr::test {

bool setThreadNice(int nice) {
  return ::setpriority(PRIO_PROCESS, static_cast<id_t>(::syscall(SYS_gettid)), nice) == 0;
}

namespace {
constexpr int kMeasuredFifoPriority = 10;
bool fifo(pid_t tid) {
  sched_param p{};
  p.sched_priority = kMeasuredFifoPriority;
  return ::sched_setscheduler(tid, SCHED_FIFO, &p) == 0;
}
}  // namespace

bool setThreadRealtime() { return fifo(static_cast<pid_t>(::syscall(SYS_gettid))); }

bool setProcessRealtime(pid_t pid) {
  std::error_code ec;
  bool ok = true;
  for (const auto& task : std::filesystem::directory_iterator("/proc/" + std::to_string(pid) + "/task", ec))
    ok = fifo(static_cast<pid_t>(std::stol(task.path().filename().string()))) && ok;
  return ok && !ec;
}

void setThreadNormal() {
  sched_param p{};
  ::sched_setscheduler(static_cast<pid_t>(::syscall(SYS_gettid)), SCHED_OTHER, &p);
  setThreadNice(0);
}

std::unique_ptr<ChildProcess> startEmulator(const std::vector<std::string>& args, const std::string& logPath,
                                            std::chrono::milliseconds timeout) {
  std::vector<std::string> argv = {binPath("vgr-sim-camera")};
  argv.insert(argv.end(), args.begin(), args.end());
  auto p = ChildProcess::spawn(argv, logPath);
  if (!p) {
    ADD_FAILURE() << "could not start " << argv[0];
    return nullptr;
  }
  if (!p->waitForLine("\"ready\"", timeout)) {
    ADD_FAILURE() << "emulator did not start (port 3956 busy?)" << (logPath.empty() ? "" : ", log: " + logPath);
    return nullptr;
  }
  return std::make_unique<ChildProcess>(std::move(*p));
}

NotifySocket::NotifySocket(std::string path) : path_(std::move(path)) {
  ::unlink(path_.c_str());
  fd_ = ::socket(AF_UNIX, SOCK_DGRAM | SOCK_CLOEXEC, 0);
  sockaddr_un sa{};
  sa.sun_family = AF_UNIX;
  std::snprintf(sa.sun_path, sizeof sa.sun_path, "%s", path_.c_str());
  if (fd_ >= 0 && ::bind(fd_, reinterpret_cast<sockaddr*>(&sa), sizeof sa) != 0) {
    ::close(fd_);
    fd_ = -1;
  }
  timeval tv{0, 100000};
  if (fd_ >= 0) ::setsockopt(fd_, SOL_SOCKET, SO_RCVTIMEO, &tv, sizeof tv);
}

NotifySocket::~NotifySocket() {
  if (fd_ >= 0) ::close(fd_);
  ::unlink(path_.c_str());
}

int NotifySocket::countFor(const std::string& what, std::chrono::milliseconds window) {
  const auto end = std::chrono::steady_clock::now() + window;
  int n = 0;
  while (fd_ >= 0 && std::chrono::steady_clock::now() < end) {
    char buf[512];
    const ssize_t got = ::recv(fd_, buf, sizeof buf, 0);
    if (got > 0 && std::string(buf, static_cast<std::size_t>(got)).find(what) != std::string::npos) ++n;
  }
  return n;
}

bool NotifySocket::waitFor(const std::string& what, std::chrono::milliseconds timeout) {
  const auto deadline = std::chrono::steady_clock::now() + timeout;
  while (fd_ >= 0 && std::chrono::steady_clock::now() < deadline) {
    char buf[512];
    const ssize_t n = ::recv(fd_, buf, sizeof buf, 0);
    if (n > 0 && std::string(buf, static_cast<std::size_t>(n)).find(what) != std::string::npos) return true;
  }
  return false;
}

std::optional<ChildProcess> spawnWithNotify(const std::vector<std::string>& argv, const std::string& logPath,
                                            const NotifySocket& notify) {
  // The child inherits the environment at fork: set it around the spawn only.
  ::setenv("NOTIFY_SOCKET", notify.path().c_str(), 1);
  auto p = ChildProcess::spawn(argv, logPath);
  ::unsetenv("NOTIFY_SOCKET");
  return p;
}

}  // namespace vgr::test
