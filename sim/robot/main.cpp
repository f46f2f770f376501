// vgr-sim-robot: behaves like an unmodified robot program polling vgrd for part poses, and
// checks every reply strictly against the dialect (docs/protocols.md).
//
//   ur    : socket_send_line("GET,<job>")  -> "GET,<job>\n"; reads up to ')' as
//           socket_read_ascii_float does.
//   abb   : SocketSend \Str:="GET,<job>#"; SocketReceive \Str reads whatever is buffered, at
//           most 80 characters, in ONE call: a reply split over two TCP segments, longer than
//           80 characters or followed by stray bytes shows up as invalid.
//   fanuc : WRITE "GET,<job>" CR LF; READ a line up to CR LF (KAREL file READ), which must be
//           the 75-byte fixed-column reply that SUB_STR/CNV_STR_REAL take apart.
//   binary: the 16-byte VGRQ request; reads exactly 40 bytes (socket_read_binary_integer(10))
//           and checks magic and length.
// (`strict` is a push protocol, not a poll: tests/integration/robot_wire_test.cpp plays it.)
//
// Output: one line per reply on stdout (JSON with --json); diagnostics on stderr.
// A reply that does not come within --timeout-ms counts as invalid (the protocol promises a
// reply, possibly an error status, before the robot's read times out); the connection is
// then re-opened so a late reply cannot pair with the next request. A connection closed by
// the daemon is re-opened (for up to 10 s) and the unanswered request sent again.
// Exit: 0 all replies valid, 1 any invalid reply, 2 usage or connection failure.
// Single-threaded: one io_context run by main().
#include <array>
#include <chrono>
#include <cmath>
#include <csignal>
#include <cstdint>
#include <iostream>
#include <optional>
#include <string>
#include <string_view>
#include <vector>

#include <fmt/core.h>
#include <CLI/CLI.hpp>

#include "core/cli.hpp"
#include <boost/asio/connect.hpp>
#include <boost/asio/io_context.hpp>
#include <boost/asio/ip/tcp.hpp>
#include <boost/asio/signal_set.hpp>
#include <boost/asio/steady_timer.hpp>
#include <boost/asio/write.hpp>
#include <nlohmann/json.hpp>

#include "core/log.hpp"
#include "protocol/robot_codec.hpp"
#include "protocol/robot_reply.hpp"

namespace {

namespace asio = boost::asio;
using tcp = asio::ip::tcp;
using boost::system::error_code;
using Json = nlohmann::ordered_json;
using vgr::protocol::Dialect;

constexpr auto kConnectWindow = std::chrono::seconds(10);
constexpr auto kConnectRetryDelay = std::chrono::milliseconds(200);
constexpr std::size_t kMaxReplyBytes = 1024;  // ur/fanuc: give up looking for the end after this

struct Options {
  std::string dialect;
  std::string name;  // "robot" field; defaults to the dialect
  std::string host = "127.0.0.1";
  std::uint16_t port = 0;
  int job = 1;
  std::uint64_t count = 0;  // 0 = until SIGTERM/SIGINT
  int intervalMs = 100;
  int timeoutMs = 3000;
  bool json = false;
};

// A reply checked against the dialect (protocol/robot_reply.hpp); the numbers are set only
// when valid.
struct Parsed {
  bool valid = false;
  std::string error;
  int status = 0;
  long long cycle = 0;
  double xMm = 0, yMm = 0, zMm = 0, rzDeg = 0;
};

Parsed parseReply(Dialect dialect, const std::string& raw) {
  Parsed p;
  const vgr::Result<vgr::protocol::ParsedReply> r = vgr::protocol::parseRobotReply(dialect, raw);
  if (!r) {
    p.error = r.error().message;
    return p;
  }
  p.valid = true;
  p.status = r->status;
  p.cycle = r->cycle;
  p.xMm = r->xMm;
  p.yMm = r->yMm;
  p.zMm = r->zMm;
  p.rzDeg = r->rzDeg;
  return p;
}

class SimRobot {
 public:
  SimRobot(asio::io_context& io, Options opt, Dialect dialect)
      : io_(io), opt_(std::move(opt)), dialect_(dialect), socket_(io), timer_(io), signals_(io, SIGINT, SIGTERM) {
    switch (dialect_) {
      case Dialect::Ur: request_ = "GET," + std::to_string(opt_.job) + "\n"; break;
      case Dialect::Fanuc: request_ = "GET," + std::to_string(opt_.job) + "\r\n"; break;
      case Dialect::Binary: request_ = vgr::protocol::binary::encodeRequest(vgr::protocol::binary::kCmdGet, opt_.job); break;
      default: request_ = "GET," + std::to_string(opt_.job) + "#"; break;
    }
  }

  void start() {
    signals_.async_wait([this](const error_code& ec, int) {
      if (!ec) finish();
    });
    error_code ec;
    tcp::resolver resolver(io_);
    endpoints_ = resolver.resolve(opt_.host, std::to_string(opt_.port), ec);
    if (ec) {
      std::cerr << "vgr-sim-robot: cannot resolve " << opt_.host << ": " << ec.message() << "\n";
      finish(2);
      return;
    }
    beginConnect();
  }

  int exitCode() const { return exitCode_; }

 private:
  void beginConnect() {
    connectDeadline_ = std::chrono::steady_clock::now() + kConnectWindow;
    tryConnect();
  }

  void tryConnect() {
    if (done_) return;
    error_code ignored;
    socket_.close(ignored);
    asio::async_connect(socket_, endpoints_, [this](const error_code& ec, const tcp::endpoint&) {
      if (done_) return;
      if (!ec) {
        error_code optEc;
        socket_.set_option(tcp::no_delay(true), optEc);
        vgr::log::info("sim", "{}: connected to {}:{}", opt_.name, opt_.host, opt_.port);
        rx_.clear();
        exchange();
        return;
      }
      if (std::chrono::steady_clock::now() >= connectDeadline_) {
        std::cerr << "vgr-sim-robot: cannot connect to " << opt_.host << ":" << opt_.port
                  << " for 10 s: " << ec.message() << "\n";
        finish(2);
        return;
      }
      timer_.expires_after(kConnectRetryDelay);
      timer_.async_wait([this](const error_code& wec) {
        if (!wec) tryConnect();
      });
    });
  }

  // One request/reply, with the robot's read timeout.
  void exchange() {
    if (done_) return;
    const std::uint64_t id = ++exchangeId_;
    timer_.expires_after(std::chrono::milliseconds(opt_.timeoutMs));
    timer_.async_wait([this, id](const error_code& ec) {
      if (!ec && id == exchangeId_) onTimeout();
    });
    asio::async_write(socket_, asio::buffer(request_), [this, id](const error_code& ec, std::size_t) {
      if (id != exchangeId_ || done_) return;
      if (ec) {
        connectionLost(ec);
        return;
      }
      readReply(id);
    });
  }

  void readReply(std::uint64_t id) {
    if (dialect_ != Dialect::Abb) {
      readFramed(id);
      return;
    }
    socket_.async_read_some(asio::buffer(abbBuf_), [this, id](const error_code& ec, std::size_t n) {
      if (id != exchangeId_ || done_) return;
      if (ec) {
        connectionLost(ec);
        return;
      }
      replied(std::string(abbBuf_.data(), n));
    });
  }

  // Bytes of rx_ that make one complete reply, or 0 while incomplete: ur up to ')' like
  // socket_read_ascii_float, fanuc up to CR LF like KAREL's READ, binary 40 bytes.
  std::size_t frameLength() const {
    if (dialect_ == Dialect::Binary) return rx_.size() >= vgr::protocol::binary::kReplyBytes ? vgr::protocol::binary::kReplyBytes : 0;
    const std::string_view end = dialect_ == Dialect::Ur ? ")" : "\r\n";
    const std::size_t at = rx_.find(end);
    return at == std::string::npos ? 0 : at + end.size();
  }

  // Accumulates until frameLength() says a reply is complete; bytes after it stay for the
  // next reply (and make it invalid, as they would confuse a robot program too).
  void readFramed(std::uint64_t id) {
    if (const std::size_t n = frameLength(); n > 0) {
      std::string raw = rx_.substr(0, n);
      rx_.erase(0, n);
      replied(raw);
      return;
    }
    if (rx_.size() >= kMaxReplyBytes) {
      retire();
      std::string raw = std::move(rx_);
      rx_.clear();
      record(raw, "no end of reply within 1024 bytes");
      reopen();
      return;
    }
    socket_.async_read_some(asio::buffer(chunk_), [this, id](const error_code& ec, std::size_t n) {
      if (id != exchangeId_ || done_) return;
      if (ec) {
        connectionLost(ec);
        return;
      }
      rx_.append(chunk_.data(), n);
      readFramed(id);
    });
  }

  // Ends the current exchange: its pending timer and I/O callbacks become no-ops.
  void retire() {
    ++exchangeId_;
    timer_.cancel();
  }

  void replied(const std::string& raw) {
    retire();
    record(raw, {});
    next();
  }

  void onTimeout() {
    retire();
    std::string partial = std::move(rx_);
    rx_.clear();
    record(partial, "no reply within " + std::to_string(opt_.timeoutMs) + " ms");
    reopen();
  }

  // The daemon closed the connection (or it broke) before replying: not a reply at all.
  void connectionLost(const error_code& ec) {
    retire();
    ++reconnects_;
    vgr::log::info("sim", "{}: connection lost ({}), reconnecting", opt_.name, ec.message());
    error_code ignored;
    socket_.close(ignored);
    beginConnect();  // then the same request again
  }

  // After a timeout or a framing error the stream is out of step: start afresh.
  void reopen() {
    if (done_) return;
    ++reconnects_;
    error_code ignored;
    socket_.close(ignored);
    if (countReached()) {
      finish();
      return;
    }
    beginConnect();
  }

  bool countReached() const { return opt_.count != 0 && replies_ >= opt_.count; }

  void next() {
    if (done_) return;
    if (countReached()) {
      finish();
      return;
    }
    timer_.expires_after(std::chrono::milliseconds(opt_.intervalMs));
    timer_.async_wait([this](const error_code& ec) {
      if (!ec) exchange();
    });
  }

  // Prints and counts one reply (or one timeout, which is an invalid reply). Binary replies
  // are shown as hex.
  void record(const std::string& rawBytes, const std::string& failure) {
    std::string raw = rawBytes;
    if (dialect_ == Dialect::Binary) {
      raw.clear();
      for (const char c : rawBytes) raw += fmt::format("{:02x}", static_cast<unsigned char>(c));
    }
    ++replies_;
    Parsed p;
    if (failure.empty()) {
      p = parseReply(dialect_, rawBytes);
    } else {
      p.error = failure;
    }
    if (p.valid) {
      ++valid_;
      if (p.status == 0) ++ok_;
    } else {
      ++invalid_;
    }

    if (opt_.json) {
      Json line;
      line["robot"] = opt_.name;
      line["n"] = replies_;
      line["valid"] = p.valid;
      if (p.valid) {
        line["status"] = p.status;
        line["cycle"] = p.cycle;
        line["x_mm"] = p.xMm;
        line["y_mm"] = p.yMm;
        line["z_mm"] = p.zMm;
        line["rz_deg"] = p.rzDeg;
      } else {
        line["error"] = p.error;
      }
      line["raw"] = raw;
      std::cout << line.dump(-1, ' ', false, Json::error_handler_t::replace) << std::endl;
    } else if (p.valid) {
      std::cout << fmt::format("{} #{} valid status={} cycle={} x={:.3f} y={:.3f} z={:.3f} rz={:.3f} raw={}", opt_.name,
                               replies_, p.status, p.cycle, p.xMm, p.yMm, p.zMm, p.rzDeg, raw)
                << std::endl;
    } else {
      std::cout << opt_.name << " #" << replies_ << " INVALID (" << p.error
                << ") raw=" << Json(raw).dump(-1, ' ', false, Json::error_handler_t::replace) << std::endl;
    }
  }

  void finish(int forcedCode = -1) {
    if (done_) return;
    done_ = true;
    Json summary;
    summary["robot"] = opt_.name;
    summary["replies"] = replies_;
    summary["valid"] = valid_;
    summary["invalid"] = invalid_;
    summary["ok"] = ok_;
    summary["reconnects"] = reconnects_;
    std::cout << summary.dump() << std::endl;
    exitCode_ = forcedCode >= 0 ? forcedCode : (invalid_ > 0 ? 1 : 0);
    error_code ignored;
    socket_.close(ignored);
    timer_.cancel();
    signals_.cancel(ignored);
    io_.stop();
  }

  asio::io_context& io_;
  const Options opt_;
  const Dialect dialect_;
  tcp::socket socket_;
  asio::steady_timer timer_;  // connect retry, reply timeout, interval: one at a time
  asio::signal_set signals_;
  tcp::resolver::results_type endpoints_;
  std::chrono::steady_clock::time_point connectDeadline_{};
  std::string request_;
  std::string rx_;                                               // ur: bytes read so far
  std::array<char, 256> chunk_{};                              // ur, fanuc, binary: one read
  std::array<char, vgr::protocol::kAbbMaxReplyChars> abbBuf_{};  // abb: one SocketReceive
  std::uint64_t exchangeId_ = 0;                                 // bumps retire the callbacks of a finished exchange
  std::uint64_t replies_ = 0, valid_ = 0, invalid_ = 0, ok_ = 0, reconnects_ = 0;
  bool done_ = false;
  int exitCode_ = 0;
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-sim-robot: a UR or ABB robot program polling vgrd for poses, validating every reply"};
  vgr::cli::showDefaults(app);
  Options opt;
  app.add_option("--dialect", opt.dialect, "ur | abb | fanuc | binary")->required()->check(CLI::IsMember({"ur", "abb", "fanuc", "binary"}));
  app.add_option("--name", opt.name, "robot name printed in the output (default: the dialect)");
  app.add_option("--host", opt.host, "vgrd address");
  app.add_option("--port", opt.port, "robot endpoint port")->required()->check(CLI::Range(1, 65535));
  app.add_option("--job", opt.job, "job number sent in GET,<job>")->check(CLI::Range(1, 32767));
  app.add_option("--count", opt.count, "replies to collect, 0 = until SIGTERM/SIGINT");
  app.add_option("--interval-ms", opt.intervalMs, "pause between a reply and the next request")
      ->check(CLI::Range(0, 3600000));
  app.add_option("--timeout-ms", opt.timeoutMs, "read timeout per reply")
      ->check(CLI::Range(1, 3600000));
  app.add_flag("--json", opt.json, "one JSON object per line");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  const std::optional<Dialect> dialect = vgr::protocol::parseDialect(opt.dialect);
  if (!dialect) return 2;  // unreachable: checked by CLI11
  if (opt.name.empty()) opt.name = opt.dialect;

  try {
    asio::io_context io;
    SimRobot robot(io, opt, *dialect);
    robot.start();
    io.run();
    return robot.exitCode();
  } catch (const std::exception& e) {
    std::cerr << "vgr-sim-robot: " << e.what() << "\n";
    return 2;
  }
}
