// A watchdog that means something (docs/plant.md, "Watchdog"): the real vgrd on the
// simulated cell, run as systemd runs it with WatchdogSec (NOTIFY_SOCKET + WATCHDOG_USEC),
// pings WATCHDOG=1 while its threads make progress and stops when one of them is frozen.
// The freeze is real and needs no hook in vgrd: ptrace(PTRACE_SEIZE + PTRACE_INTERRUPT)
// stops exactly one thread of the running daemon (found by its name in /proc), the others
// run on; PTRACE_DETACH lets it go again.
#include <gtest/gtest.h>

#include <sys/ptrace.h>
#include <sys/wait.h>

#include <csignal>
#include <thread>

#include <cerrno>
#include <chrono>
#include <cstdlib>
#include <cstring>
#include <filesystem>
#include <fstream>
#include <string>

#include "tests/support/sim_cell.hpp"

namespace {

using namespace std::chrono_literals;

// WatchdogSec=2 for this test (the unit ships 10 s): vgrd checks its threads every 500 ms
// (a quarter of it) and pings when all are well.
constexpr const char* kWatchdogUsec = "2000000";

class WatchdogVgrd : public vgr::test::SimCell {
 protected:
  void SetUp() override {
    ::setenv("WATCHDOG_USEC", kWatchdogUsec, 1);  // inherited by vgrd at spawn only
    startCell();
    ::unsetenv("WATCHDOG_USEC");
  }

  // The thread of vgrd named `name` (/proc/<pid>/task/<tid>/comm), or -1.
  pid_t threadNamed(const std::string& name) const {
    const std::filesystem::path tasks = "/proc/" + std::to_string(vgrd_->pid()) + "/task";
    for (const auto& e : std::filesystem::directory_iterator(tasks)) {
      std::ifstream comm(e.path() / "comm");
      std::string n;
      std::getline(comm, n);
      if (n == name) return static_cast<pid_t>(std::stoi(e.path().filename().string()));
    }
    return -1;
  }

  // Stops one thread of vgrd (the others run on); true when it is stopped.
  static bool freeze(pid_t tid) {
    if (::ptrace(PTRACE_SEIZE, tid, nullptr, nullptr) != 0) {
      ADD_FAILURE() << "PTRACE_SEIZE " << tid << ": " << std::strerror(errno);
      return false;
    }
    if (::ptrace(PTRACE_INTERRUPT, tid, nullptr, nullptr) != 0) return false;
    int status = 0;
    return ::waitpid(tid, &status, __WALL) == tid && WIFSTOPPED(status);
  }
  static void thaw(pid_t tid) { ::ptrace(PTRACE_DETACH, tid, nullptr, nullptr); }

  // Freezes `thread`, checks the pings stop within its stall limit (+ one check period) and
  // stay away, that the log names it, and that the pings come back after the thaw.
  void expectPingsStopWhileFrozen(const std::string& thread, std::chrono::milliseconds stallLimit,
                                  const std::string& logName) {
    ASSERT_GE(notify_->countFor("WATCHDOG=1", 2000ms), 1) << "no pings before the freeze\n" << log("vgrd.log");
    const pid_t tid = threadNamed(thread);
    ASSERT_GT(tid, 0) << "no thread named " << thread;
    ASSERT_TRUE(freeze(tid));
    // Pings go on until the thread's silence passes its limit, then stop.
    const auto frozenAt = Clock::now();
    (void)notify_->countFor("WATCHDOG=1", stallLimit + 1000ms);
    const int whileStalled = notify_->countFor("WATCHDOG=1", 3000ms);
    const auto frozenFor = Clock::now() - frozenAt;
    thaw(tid);
    EXPECT_EQ(whileStalled, 0) << thread << " frozen for "
                               << std::chrono::duration_cast<std::chrono::milliseconds>(frozenFor).count()
                               << " ms, still pinging\n"
                               << log("vgrd.log");
    EXPECT_NE(log("vgrd.log").find("watchdog: the " + logName + " thread has made no progress"), std::string::npos)
        << log("vgrd.log");
    // Thawed: it beats again and the pings resume.
    EXPECT_TRUE(notify_->waitFor("WATCHDOG=1", 2000ms)) << log("vgrd.log");
    EXPECT_NE(log("vgrd.log").find("pings resumed"), std::string::npos);
  }
};

TEST_F(WatchdogVgrd, AFrozenCycleThreadStopsThePings) {
  // cycle_deadline_ms 1500 in the sim cell: stall limit 3.5 s.
  expectPingsStopWhileFrozen("vgr-cycle", 3500ms, "cycle");
}

TEST_F(WatchdogVgrd, AFrozenModbusThreadStopsThePings) {
  expectPingsStopWhileFrozen("vgr-modbus", 3000ms, "Modbus server 127.0.0.1:1502");
}

TEST_F(WatchdogVgrd, AnIdleCellKeepsPinging) {
  // No trigger for 5 s: every thread idles in bounded waits and beats; pings every ~500 ms.
  EXPECT_GE(notify_->countFor("WATCHDOG=1", 5000ms), 7) << log("vgrd.log");
  EXPECT_EQ(log("vgrd.log").find("made no progress"), std::string::npos) << log("vgrd.log");
  EXPECT_EQ(log("vgrd.log").find("pause:"), std::string::npos) << log("vgrd.log");
}

// A pause of the whole process (docs/robustness.md "Pauses"): SIGSTOP holds every thread of
// vgrd for 1.5 s, SIGCONT lets them go. The I/O thread's next watchdog tick comes ~1.5 s late;
// vgrd logs the pause with the threads' silences and the verdict its scheduler figures give:
// not runnable (stopped), which is neither "no CPU" nor "busy".
TEST_F(WatchdogVgrd, AStoppedProcessLogsThePauseAndWhy) {
  ASSERT_GE(notify_->countFor("WATCHDOG=1", 2000ms), 1) << log("vgrd.log");
  ASSERT_EQ(::kill(vgrd_->pid(), SIGSTOP), 0);
  std::this_thread::sleep_for(1500ms);
  ASSERT_EQ(::kill(vgrd_->pid(), SIGCONT), 0);
  EXPECT_TRUE(notify_->waitFor("WATCHDOG=1", 2000ms)) << log("vgrd.log");
  std::string text;
  for (int i = 0; i < 20 && (text = log("vgrd.log")).find("pause:") == std::string::npos; ++i)
    std::this_thread::sleep_for(100ms);
  const auto at = text.find("pause: the I/O thread's watchdog timer fired ");
  ASSERT_NE(at, std::string::npos) << text;
  const int lateMs = std::stoi(text.substr(at + std::string("pause: the I/O thread's watchdog timer fired ").size()));
  EXPECT_GE(lateMs, 1000) << text.substr(at, 600);  // stopped 1500 ms; the tick was due within 500 ms of the stop
  const std::string line = text.substr(at, text.find('\n', at) - at);
  EXPECT_NE(line.find("cycle "), std::string::npos) << line;
  EXPECT_NE(line.find("not runnable"), std::string::npos) << line;
}

}  // namespace
