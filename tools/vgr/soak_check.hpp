// `vgr soak`'s verdict (docs/robustness.md): every trigger checked from the PLC's side, every
// robot reply from the robot's side, both against vgrd's journal. Pure: records in, one
// JSON summary and a list of problems out.
//
// PLC, per trigger (TRIGGER written): answered exactly once (RESULT_VALID with RESULT_ID =
// the ACQ_ID acknowledged for it; ACQ_IDs never repeat), within cycle_deadline_ms + 100 ms
// (vgrd's Modbus backstop) + slack, with OK or a typed error; its journal line exists once
// with the same status and pose. A trigger whose vgrd was killed (-9) before it was
// answered is `interrupted`, not lost: nothing can answer it.
// Robots, per request: a reply well-formed to the byte, within reply_deadline_ms + slack; a
// cycle reaches a robot at most once and with the journal's pose; a malformed request gets
// exactly its error status; and no cycle is `missed`: one that a robot was waiting for (or
// asked for before a newer one came) and never got (a part handed to a connection that
// was dropped must come back to the robot's next request). "Next" is by vgrd's cycle order.
// A cycle whose result vgrd's I/O thread took up only when the next result was already
// there (vgrd logged its late hand-over) is not judged but counted: a request that reached
// vgrd meanwhile was read after both, and "the newest" is then rightly the next one.
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <vector>

#include <nlohmann/json.hpp>

#include "tools/vgr/soak_actors.hpp"

namespace vgr::tools::soak {

struct JournalEntry {
  std::uint32_t cycle = 0;
  double time = 0;       // trigger time, Unix s
  double publish = 0;    // time + total_ms: when the result went out
  std::string trigger;   // modbus, robot, operator
  int job = 0;
  int status = 0;
  bool hasPart = false;
  double x = 0, y = 0, rz = 0;
};

struct CheckInput {
  std::vector<JournalEntry> journal;     // every complete line of every journal file
  std::vector<TriggerRecord> plc;
  struct Robot {
    RobotOptions options;
    std::vector<RobotRequestRecord> records;
  };
  std::vector<Robot> robots;
  std::vector<double> kills;             // wall times vgrd was killed (-9)
  // vgrd's own clock: cycles whose result reached the robots' side (its I/O thread) late,
  // in ms after publish, from vgrd's "robots got the result N ms after" log lines.
  std::map<std::uint32_t, double> lateHandOverMs;
  // vgrd's "pause:" lines (daemon/pause_probe.hpp), reported in the summary as they are:
  // the evidence of why vgrd did not run (docs/robustness.md "Pauses").
  std::vector<std::string> pauses;
  int cycleDeadlineMs = 1500;
  int replyDeadlineMs = 1500;
  int slackMs = 250;                     // measurement slack (polling, scheduling) on every deadline
  bool allowLateTyped = false;           // late answers with a typed error are not failures
};

struct CheckResult {
  nlohmann::ordered_json summary;        // triggers, ok, typed errors by code, lost, ...
  std::vector<std::string> problems;     // the first few of each kind, for the log
  bool pass = false;
};

// The late hand-overs vgrd logged (daemon/vgrd_app.cpp, handOver()): cycle -> ms. Lines
// vgrd's rate limit held back are simply absent (those cycles are then judged as usual).
std::map<std::uint32_t, double> readLateHandOvers(const std::string& vgrdLogPath);

// vgrd's "pause:" warnings, each from "pause:" to the end of its line.
std::vector<std::string> readPauses(const std::string& vgrdLogPath);

// Reads <path>, <path>.1 ... (rotated) line by line; lines that do not parse are counted.
std::vector<JournalEntry> readJournals(const std::string& path, int& unparsable, int& files);

CheckResult check(const CheckInput& in);

}  // namespace vgr::tools::soak
