// The `strict` dialect's exchange (paper 002, section 2: "a MoveJ command was initiated by
// the vision system server, sending a 'MoveJ_pose' command, to which the client responded
// with a 'MoveJ_pose_wait_pos' handshake. Subsequently, the server transmitted the target
// {x, y, z, Rx, Ry, Rz} coordinates encoded in a byte frame and awaited confirmation ... via
// a 'MoveJ_pose_done' response. In cases of an incorrect or absent response, the vision
// system treated the move command as unsuccessful ... and aborted the operation").
//
// Eye-in-hand snapshots (a camera on the flange, docs/protocols.md): with tokens.snapshot
// set, the robot drives. It sends "<snapshot>(x,y,z,rx,ry,rz)" (its flange pose, metres and
// a rotation vector; or URScript's "p[...]") when it stands at the snapshot pose; the
// session triggers a cycle with that pose and then runs the four steps above for the part,
// or, when the cycle has nothing to move, sends "<none>(<status>)" (e.g. "MoveJ_none(1)",
// a code of the status table).
//
// Pure state machine: bytes in, bytes to send and outcomes out; no sockets, no timers
// (the caller owns the step timer and calls onTimeout()). One object per connection, used
// from one thread.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>

#include "core/pose.hpp"
#include "core/status.hpp"

namespace vgr::protocol {

// Tokens as a robot program spells them; configurable so an existing program runs
// unchanged (cell.yaml robots[i].strict). Tokens are matched exactly (case-sensitive).
struct StrictTokens {
  std::string command = "MoveJ_pose";          // daemon -> robot
  std::string ready = "MoveJ_pose_wait_pos";   // robot -> daemon: send the pose now
  std::string done = "MoveJ_pose_done";        // robot -> daemon: the move finished
  std::string lineEnd;                         // appended to what the daemon sends: "", "\n" or "\r\n"
  std::string snapshot;                        // robot -> daemon, then its flange pose; "" = push mode
  std::string none = "MoveJ_none";             // daemon -> robot: a snapshot with nothing to move
};

// Longest token accepted in the config (and the most bytes quoted back in a log).
inline constexpr std::size_t kMaxStrictTokenChars = 64;
// Longest snapshot pose frame accepted after the snapshot token (a frame is ~60 bytes).
inline constexpr std::size_t kMaxStrictPoseFrameChars = 160;

class StrictExchange {
 public:
  enum class Step {
    Idle,         // no exchange running: bytes from the robot are unexpected (but for a
                  // snapshot, when tokens.snapshot is set)
    AwaitResult,  // a snapshot arrived: the session waits for its cycle (begin() or noResult())
    AwaitReady,   // command sent, waiting for tokens.ready
    AwaitDone,    // pose frame sent, waiting for tokens.done
  };

  enum class EventKind {
    None,       // need more bytes (or nothing happened)
    SendPose,   // the ready token arrived: send `bytes` (the pose frame + lineEnd) now
    Completed,  // the done token arrived: the exchange succeeded, back to Idle
    Failed,     // aborted: `status` and `detail` say why, back to Idle; resynchronise the
                // stream (vgrd closes the connection)
    Unexpected, // bytes arrived while Idle; `detail` quotes them; they were discarded
    Snapshot,   // tokens.snapshot and a valid flange pose arrived: `pose`; now AwaitResult
    BadSnapshot,// tokens.snapshot with a pose that is not one: `status` (-2) and `detail`;
                // answer with noResult(status) (still Idle)
  };

  struct Event {
    EventKind kind = EventKind::None;
    std::string bytes;   // SendPose: what to write
    Status status = Status::Ok;
    std::string detail;  // Failed / Unexpected / BadSnapshot: for the log, printable ASCII
    Pose pose;           // Snapshot: T_base_flange, mm + unit quaternion
  };

  explicit StrictExchange(StrictTokens tokens);

  // Starts an exchange for one pose frame (formatStrictPoseFrame). Returns the bytes to
  // send now (tokens.command + lineEnd). Precondition: step() is Idle or AwaitResult.
  std::string begin(std::string poseFrame);
  // A snapshot's cycle has nothing to move: the bytes to send ("<none>(<status>)" +
  // lineEnd); back to Idle.
  std::string noResult(Status status);
  bool snapshotMode() const { return !tokens_.snapshot.empty(); }

  // Received bytes; then call poll() until it returns None.
  void feed(std::string_view bytes);
  Event poll();

  // The step timer expired (nothing, or not enough, arrived): Failed with
  // Status::ProcessingTimeout. None when Idle.
  Event onTimeout();
  // The connection closed or broke: Failed with Status::Internal. None when Idle.
  Event onClosed();

  Step step() const { return step_; }
  // The token the current step waits for ("" when Idle).
  const std::string& expected() const;

 private:
  Event failNow(Status status, std::string detail);
  Event pollSnapshot();

  StrictTokens tokens_;
  Step step_ = Step::Idle;
  std::string poseFrame_;
  std::string rx_;
};

// Printable rendering of received bytes for a log line (at most kMaxStrictTokenChars,
// control and non-ASCII bytes as \xNN).
std::string printable(std::string_view bytes);

}  // namespace vgr::protocol
