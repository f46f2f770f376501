// `vgr soak`: the fault-injection harness (docs/robustness.md). Runs the simulated cell —
// camera emulator and vgrd as processes (vgrd restarted as systemd would: 2 s after it
// died, READY=1 awaited on a NOTIFY_SOCKET of ours), a PLC doing the Modbus handshake at a
// chosen rate and robots of every dialect (ur, abb, fanuc, binary polling GET; strict
// pushed to) as threads over real sockets — and injects faults on a schedule or at random
// by seed: camera killed and restarted, camera frozen (SIGSTOP/SIGCONT), GVSP packet loss,
// robots that drop mid-request or stop reading, a PLC that drops its connection
// mid-handshake, malformed Modbus and robot frames, vgrd killed -9. Then checks every
// trigger from the PLC's and the robots' side against the journal (tools/vgr/soak_check.hpp)
// and prints one JSON summary line.
#pragma once

#include <cstdint>
#include <string>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct SoakOptions {
  long long triggers = 0;         // stop after this many PLC triggers (0: the duration decides)
  double durationS = 0;           // s: stop after this long (0: the trigger count decides)
  double rateHz = 10;             // PLC triggers per second
  std::uint64_t seed = 1;         // random faults and their parameters
  std::string faults = "schedule";  // schedule (round robin over the kinds), random, none
  double faultEveryS = 7;         // s: spacing (schedule) or mean spacing (random) of faults
  double killEveryS = 0;          // s: random mode, mean spacing of vgrd kills (0: like the others)
  std::string kinds;              // comma-separated fault kinds (empty: all)
  double warmupS = 10;            // s: no fault before; RSS is first taken after it
  int slackMs = 250;              // ms of measurement slack on every deadline (polling, scheduling)
  bool allowLateTyped = false;    // a late answer with a typed error is no failure (the long run)
  double lossBurst = 0.01;        // GVSP packet loss while a loss burst is on
  std::string binDir;             // vgrd and vgr-sim-camera; empty: next to this executable
  std::string workDir;            // empty: a fresh /tmp/vgr-soak-* folder
};

// 0: no trigger lost, duplicated, misdelivered or (unless allowed) late, and every robot and
// journal check passed; 1: a check failed; 2: the cell could not be started.
int runSoak(const SoakOptions& options);

class SoakCommand final : public OptionsSubcommand<SoakOptions, runSoak> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
