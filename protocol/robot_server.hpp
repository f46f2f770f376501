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
  // Open connections at most. When full, a new connection from an address that already
  // has one replaces the one of them silent the longest (a robot that rebooted or re-ran
  // its program leaves a stale socket behind); from any other address it is closed at once.
  std::size_t maxClients = 8;
  // Peer IP addresses allowed to connect (numeric, v4 or v6); empty = anyone. Others are
  // closed at once with a warning.
  std::vector<std::string> allowedClients;
  // Request dialects: a connection with no byte from the robot for this long, and no
  // request in progress, is closed (ms; 0 = never). Not applied to the strict dialect
  // (vgrd speaks first there; its step timeout covers a silent robot).
  int idleTimeoutMs = 0;
  // Abb dialect only: how a reply writes the rotation (Z-Y-X Euler or quaternion).
  AbbRotation abbRotation = AbbRotation::EulerZyx;
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
// the connection (for a robot that had closed its sending side: and the robot did not
// reset the connection on it within 50 ms, i.e. it still reads); false when it was not
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

 private:
  struct Listener;
  std::shared_ptr<Listener> listener_;  // shared with its sessions' pending operations
};

}  // namespace vgr::protocol
