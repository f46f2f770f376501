// The actors of `vgr soak` (docs/robustness.md): a PLC doing the Modbus level handshake at a
// chosen rate, robots of every dialect polling vgrd, and an attacker sending malformed
// frames, each on a thread of its own over real sockets. Each records, event by event,
// what it saw (with wall-clock times, so the checker can line events up with vgrd's
// journal); faults reach them through atomic requests they act on at their next step.
// Threads: every actor runs on its own thread between start() and stop(); its record is
// read only after stop().
#pragma once

#include <atomic>
#include <chrono>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <thread>
#include <vector>

#include "protocol/wire_types.hpp"

namespace vgr::tools::soak {

using Clock = std::chrono::steady_clock;

// Seconds since the Unix epoch, as the journal's `time` field.
double wallNow();

// What every actor needs to know about vgrd's lifecycle (the supervisor updates it).
struct CellState {
  std::atomic<int> incarnation{0};   // bumps when vgrd is killed
  std::atomic<bool> vgrdUp{false};   // READY=1 seen and not killed since
  std::atomic<bool> draining{false}; // the PLC starts no new trigger (it finishes the one in flight)
  std::atomic<bool> stop{false};     // every actor ends its loop
};

// ---- PLC ---------------------------------------------------------------------------------

struct TriggerRecord {
  int n = 0;
  double t0 = 0;               // wall time of the TRIGGER write (journal clock)
  int incarnation = 0;         // of vgrd when the trigger was written
  bool acked = false;          // TRIGGER_ACK seen
  std::uint16_t acqId = 0;     // ACQ_ID read with TRIGGER_ACK
  bool answered = false;       // RESULT_VALID seen
  std::uint16_t resultId = 0;  // RESULT_ID read with RESULT_VALID
  int status = 0;              // ERROR_CODE read with RESULT_VALID
  bool refused = false;        // answered -3 at once (ACQ_ID/RESULT_ID unchanged by protocol)
  double x = 0, y = 0, rz = 0; // mm, deg (the best part), when status 0
  double latencyMs = 0;        // TRIGGER write -> RESULT_VALID seen
  bool interrupted = false;    // vgrd was killed before it was answered
  bool plcDropped = false;     // the PLC dropped its connection mid-handshake (a fault)
  std::string stoppedAt;       // the handshake step it stopped in when not answered
};

struct PlcOptions {
  int port = 1502;
  int job = 1;
  double rateHz = 10;          // triggers per second (a trigger starts every 1/rate s at most)
  int stepTimeoutMs = 3000;    // one handshake step (vgrd answers within cycle deadline + 100 ms)
  long long maxTriggers = 0;   // 0: until CellState::stop
};

class PlcActor {
 public:
  PlcActor(PlcOptions options, CellState& cell);
  ~PlcActor();
  void start();
  void stop();
  // Fault: drop the Modbus connection at the next handshake step and reconnect.
  void requestDisconnect() { disconnect_ = true; }
  long long triggers() const { return issued_.load(); }
  const std::vector<TriggerRecord>& records() const { return records_; }
  std::uint64_t disconnectsDone() const { return disconnects_.load(); }

 private:
  struct Impl;
  void run();
  PlcOptions options_;
  CellState& cell_;
  std::thread thread_;
  std::vector<TriggerRecord> records_;
  std::atomic<bool> disconnect_{false};
  std::atomic<long long> issued_{0};
  std::atomic<std::uint64_t> disconnects_{0};
};

// ---- Robots ------------------------------------------------------------------------------

enum class RequestKind {
  Normal,     // GET,<job>, reply read at once
  Dropped,    // GET sent, connection closed before the reply (fault)
  Stalled,    // GET sent, reply read only after a pause (fault: robot stops reading)
  Malformed,  // a malformed request (fault); the reply must be the expected error status
};

struct RobotRequestRecord {
  RequestKind kind = RequestKind::Normal;
  double sent = 0;           // wall time the request was written
  double replied = 0;        // wall time the reply was read (0: none)
  bool answered = false;
  bool valid = false;        // the reply matched the dialect byte for byte
  std::string error;         // why not (no reply, malformed reply, unexpected status)
  int status = 0;
  long long cycle = 0;
  double x = 0, y = 0, rz = 0;  // mm, deg
  int expectedStatus = 0;    // Malformed: the status the reply must carry
  std::vector<long long> discarded;  // Dropped: cycles already in our buffer at the close
};

struct RobotOptions {
  std::string name;
  protocol::Dialect dialect = protocol::Dialect::Ur;
  int port = 0;
  int job = 1;
  int replyTimeoutMs = 3000;  // the robot program's read timeout
  int stallMs = 2500;         // how long a stalled robot does not read
};

class RobotActor {
 public:
  RobotActor(RobotOptions options, CellState& cell);
  ~RobotActor();
  void start();
  void stop();
  // Faults, acted on at the next request.
  void requestDrop() { drop_ = true; }
  void requestStall() { stall_ = true; }
  void requestMalformed() { malformed_ = true; }
  const RobotOptions& options() const { return options_; }
  const std::vector<RobotRequestRecord>& records() const { return records_; }
  std::uint64_t reconnects() const { return reconnects_.load(); }

 private:
  void run();
  void runStrict();
  RobotOptions options_;
  CellState& cell_;
  std::thread thread_;
  std::vector<RobotRequestRecord> records_;
  std::atomic<bool> drop_{false}, stall_{false}, malformed_{false};
  std::atomic<std::uint64_t> reconnects_{0};
};

// ---- Attacker (malformed Modbus frames) ----------------------------------------------------

struct AttackOutcome {
  int frames = 0;       // malformed frames sent
  int exceptions = 0;   // answered with a Modbus exception
  int served = 0;       // answered normally (the odd unit id)
  int dropped = 0;      // the connection was closed on it (malformed framing)
  int unanswered = 0;   // none of these within 1 s, or the wrong one (a defect)
};

// One burst of malformed Modbus frames from 127.0.0.2 (not a control client): a lying
// MBAP length, a bad protocol id, an unknown function code, FC17, a write outside HR 0..15,
// a read past the table, a write while read-only, an odd unit id. Blocking, a few ms.
AttackOutcome modbusGarbageBurst(int port);

}  // namespace vgr::tools::soak
