// TCP endpoint for one robot (PROTOCOLS.md: the robot is the client, always speaks first,
// and gets exactly one reply per request, in one write). Asio stays out of this header.
//
// Threads: everything runs on the ONE thread that runs the shared io_context (the daemon's
// I/O thread); RobotServer is not thread-safe. Sockets are therefore not given strands:
// the single I/O thread is their implicit strand.
#pragma once

#include <cstddef>
#include <cstdint>
#include <functional>
#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "core/result.hpp"
#include "protocol/robot_codec.hpp"
#include "protocol/robot_strict.hpp"

namespace boost::asio {
class io_context;
}

namespace vgr::protocol {

struct RobotEndpoint {
  std::string name;  // robot name from cell.yaml, used in logs and errors
  Dialect dialect = Dialect::Ur;
  bool replyLabel = false;         // replies carry the part's label and confidence (formatReply withLabel)
  std::string bind = "127.0.0.1";  // IP address ("0.0.0.0" / "::" for all) or host name
  std::uint16_t port = 0;          // 0 = ephemeral (tests); see RobotServer::port()
  // Open connections at most, and from one peer address at most (0 = maxClients). When
  // the endpoint or the new connection's address is full, the new connection takes the
  // slot of that address's stalest connection if one of them is really stale (below);
  // otherwise it is closed at once and every open connection keeps working. A robot that
  // rebooted or re-ran its program leaves such a stale socket behind; a robot waiting for
  // its reply is never stale.
  std::size_t maxClients = 8;
  std::size_t maxClientsPerAddress = 0;
  // Stale: nothing in progress (no request waiting, queued, partly received or being
  // answered; strict: no exchange running) and no byte from the robot for this long (ms, > 0).
  int staleAfterMs = 10000;
  // Peer IP addresses allowed to connect (numeric, v4 or v6); empty = anyone. Others are
  // closed at once (logged, rate-limited, and counted).
  std::vector<std::string> allowedClients;
  // Peer IP addresses that may send control requests: JOB,<n> and TRIG (binary commands 3
  // and 4). Empty = every connection may (start() logs a warning). Others get status
  // -10 NOT_PERMITTED and the connection stays; GET is open to every allowed client.
  std::vector<std::string> controlClients;
  // Request dialects: a connection with no byte from the robot for this long, and no
  // request in progress, is closed (ms; 0 = never). Not applied to the strict dialect
  // (vgrd speaks first there; its step timeout covers a silent robot).
  int idleTimeoutMs = 0;
  // Abb dialect only: how a reply writes the rotation (Z-Y-X Euler or quaternion).
  AbbRotation abbRotation = AbbRotation::EulerZyx;
  // Request dialects: the bytes of a request must be complete this long after the first of
  // them arrived, else the connection is closed (ms, > 0). A robot writes a request at
  // once; a peer dribbling bytes (slowloris) or sending a line that never ends holds its
  // slot no longer than this.
  int requestTimeoutMs = 5000;
  // Strict dialect only: the tokens and the time each step may take (ms, > 0).
  StrictTokens strict;
  int stepTimeoutMs = 10000;
};

// Strict dialect: the end of one exchange (one pose pushed to one robot connection).
struct StrictOutcome {
  std::uint32_t cycleId = 0;
  Status status = Status::Ok;  // Ok; -1 wrong token; -5 silence past the step timeout;
                               // -8 connection lost mid-exchange
  std::string detail;          // "" when Ok; otherwise what was expected and what came
};
// Called on the I/O thread after every strict exchange (after the log line).
using StrictOutcomeFn = std::function<void(const std::string& robotName, const StrictOutcome& outcome)>;

// Told, on the I/O thread, whether a reply reached the robot: true once it was written to
// the connection and the robot did not reset the connection on it within 50 ms (a robot
// that closed its socket without reading, e.g. a program aborted mid-request, answers our
// data with RST; one that read it, or only shut down its sending side, does not); false
// when it was not
// (the connection closed or was replaced before, the write failed or timed out, the robot
// reset on it, the server stopped). Called exactly once per reply that has one.
using WrittenFn = std::function<void(bool written)>;

// Sends the reply to the request it was handed for. Call exactly once, on the I/O thread
// (a call from another thread is marshalled to the I/O thread, but do not rely on it).
// Later calls, and calls after the connection closed or the server stopped, are ignored
// (their WrittenFn gets false). If every copy is destroyed without a call, the robot gets
// status INTERNAL (-8), so a handler bug never leaves a robot waiting. A caller that must
// know whether the robot got the reply (ResultStore: a part counts as delivered only then)
// passes a WrittenFn; any callable taking (const RobotReply&) converts to a ReplyFn.
class ReplyFn {
 public:
  using Fn = std::function<void(const RobotReply&, WrittenFn)>;
  ReplyFn() = default;
  template <class F>
    requires(std::is_invocable_v<F&, const RobotReply&> && !std::is_same_v<std::decay_t<F>, ReplyFn>)
  ReplyFn(F f)  // NOLINT(google-explicit-constructor): handlers pass lambdas
      : fn_([f = std::move(f)](const RobotReply& r, const WrittenFn& written) mutable {
          f(r);
          if (written) written(true);
        }) {}
  static ReplyFn withCompletion(Fn fn) {
    ReplyFn r;
    r.fn_ = std::move(fn);
    return r;
  }
  void operator()(const RobotReply& reply, WrittenFn written = {}) const {
    if (fn_) fn_(reply, std::move(written));
  }
  explicit operator bool() const { return static_cast<bool>(fn_); }

 private:
  Fn fn_;
};

// Called on the I/O thread for each well-formed request, one at a time per connection
// (the next request of the same connection waits for this one's reply). Must not block:
// keep `reply` and call it later (e.g. from a timer or a posted vision result) if the
// answer is not ready. An exception escaping the handler is logged and answered INTERNAL.
//
// Strict dialect: the session itself asks, with GET (job 0 = the robot's current job),
// whenever it is idle; a reply with status Ok is pushed to the robot through the four-step
// exchange, any other reply is not sent (statuses 2 and 3 re-ask at once, others after a
// short pause). With strict.snapshot set it asks only when the robot sent a snapshot: TRIG
// (job 0) with the robot's flange pose; a reply that is not Ok goes to the robot as
// "<none>(<status>)".
using RequestHandler = std::function<void(const std::string& robotName, const RobotRequest& req, ReplyFn reply)>;

// What one peer can make the I/O thread do is bounded (docs/robustness.md): an endpoint
// starts at most kRobotSessionsPerSecond sessions per peer address (bursts of
// kRobotSessionBurst; more are closed as soon as they are accepted), a connection of a
// request dialect gets at most kRobotRequestsPerSecond requests served (bursts of
// kRobotRequestBurst; more wait in its socket). A robot asks a few times a second; a storm
// or a flood costs a bounded share of the I/O thread instead of all of it. The listen
// backlog is drained at up to kRobotAcceptsPerSecond (an accept and a close cost a few
// microseconds): what waits there waits for every address, so a storm's leftovers must not
// stay in it (at 200 accepts/s they kept a reconnecting robot waiting ~17 s).
inline constexpr double kRobotAcceptsPerSecond = 5000, kRobotAcceptBurst = 500;
inline constexpr double kRobotSessionsPerSecond = 200, kRobotSessionBurst = 50;
inline constexpr double kRobotRequestsPerSecond = 2000, kRobotRequestBurst = 200;

// What happened to the endpoint's connections since start() (I/O thread; the 60 s summary).
// Connection events are logged at most 20 per 10 s per endpoint; these count all of them.
struct RobotServerStats {
  std::uint64_t accepted = 0;
  std::uint64_t closed = 0;             // accepted connections that ended, for any reason
  std::uint64_t refusedNotAllowed = 0;  // peer not in allowedClients
  std::uint64_t refusedFull = 0;        // endpoint or address full, nothing stale to replace
  std::uint64_t refusedRate = 0;        // over its address's kRobotSessionsPerSecond
  std::uint64_t replacedStale = 0;      // stale connections closed to make room
  std::uint64_t goneBeforeAccept = 0;   // reset by the peer before it could be looked at
  std::uint64_t controlRefused = 0;     // JOB/TRIG from outside controlClients
  std::uint64_t logLinesHeldBack = 0;   // connection log lines counted instead of written
};

class RobotServer {
 public:
  // Borrows `io` (must outlive this object). Does not touch the network.
  RobotServer(boost::asio::io_context& io, RobotEndpoint endpoint, RequestHandler handler);
  // Calls stop(); same thread contract as stop().
  ~RobotServer();
  RobotServer(const RobotServer&) = delete;
  RobotServer& operator=(const RobotServer&) = delete;

  // Binds and listens synchronously (the error names the endpoint, address and port;
  // status Internal), then accepts asynchronously on the io_context. Call before the I/O
  // thread runs the io_context, or on the I/O thread. Fails if already started (a stopped
  // server is not restarted: construct a new one).
  Result<void> start();

  // Strict dialect: observe the outcome of every exchange. Set before start().
  void onStrictOutcome(StrictOutcomeFn fn);

  // Closes the acceptor and every session (pending replies are dropped). Idempotent.
  // Call on the I/O thread, or after the io_context stopped.
  void stop();

  // The bound port (the real one when the endpoint asked for 0); 0 before start().
  std::uint16_t port() const;

  const RobotEndpoint& endpoint() const;
  // Connections currently open. I/O thread.
  std::size_t clientCount() const;
  // Counters since start(). I/O thread.
  RobotServerStats stats() const;

 private:
  struct Listener;
  std::shared_ptr<Listener> listener_;  // shared with its sessions' pending operations
};

}  // namespace vgr::protocol
