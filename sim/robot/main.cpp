// vgr-sim-robot: behaves like an unmodified robot program polling vgrd for part poses, and
// checks every reply strictly against the dialect (docs/protocols.md).
//
//   ur    : socket_send_line("GET,<job>")  -> "GET,<job>\n"; reads up to ')' as
//           socket_read_ascii_float does.
//   abb   : SocketSend \Str:="GET,<job>#"; SocketReceive \Str reads whatever is buffered, at
//           most 80 characters, in ONE call: a reply split over two TCP segments, longer than
//           80 characters or followed by stray bytes shows up as invalid. --abb-rotation
//           quaternion: the reply carries q1..q4 instead of rz, ry, rx.
//   fanuc : WRITE "GET,<job>" CR LF; READ a line up to CR LF (KAREL file READ), which must be
//           the 75-byte fixed-column reply that SUB_STR/CNV_STR_REAL take apart.
//   binary: the 16-byte VGRQ request; reads exactly 40 bytes (socket_read_binary_integer(10))
//           and checks magic and length.
// --reply-label: the endpoint's `reply_label: true` replies (label and confidence after the
// pose: ur 10 values, abb 2 more fields, fanuc 85 bytes, binary 48 bytes), checked as strictly.
// --check-order ORDER [--label N] --truth FILE --journal FILE: at the end, whether this robot
// got exactly the parts its part order says, against the emulator's truth and vgrd's journal
// (sim/sort_check.hpp); the summary line gets a "check" object, and a failed check exits 1.
// (`strict` is a push protocol, not a poll: tests/integration/robot_wire_test.cpp plays it.)
// Every reply is parsed with all six degrees of freedom and printed as x, y, z mm and the
// Z-Y-X Euler angles rz, ry, rx in degrees (the journal's convention), whatever the dialect's
// own notation. --snapshot POSE makes each request an eye-in-hand snapshot,
// "TRIG,<job>,<pose>", the flange pose written in the dialect's own notation (ur: URScript's
// printed pose p[...] in m/rad; abb: RAPID's ValToStr [[x,y,z],[q1,q2,q3,q4]]; fanuc:
// x,y,z,w,p,r as KAREL writes them; binary: the 40-byte request).
//
// --program FILE... --config CELL (abb, fanuc, ur): plays an example robot program of
// examples/robot/ that applies offsets (sim/robot/robot_program.hpp): sends the program's
// own requests (RAPID's JOB,<n># once per connection, then its GET), and for every OK
// reply prints where the program would move the tool and which part pose that picks
// ("part_x_mm" ... in the base frame), for a test to hold against the renderer's truth.
//
// Output: one line per reply on stdout (JSON with --json); diagnostics on stderr.
// A reply that does not come within --timeout-ms counts as invalid (the protocol promises a
// reply, possibly an error status, before the robot's read times out); the connection is
// then re-opened so a late reply cannot pair with the next request. A connection closed by
// the daemon is re-opened (for up to 10 s) and the unanswered request sent again.
// Exit: 0 all replies valid, 1 any invalid reply, 2 usage or connection failure.
// Single-threaded: one io_context run by main().

#include <algorithm>
#include <array>
#include <charconv>
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

#include "config/cell_config.hpp"
#include "core/log.hpp"
#include "core/pose.hpp"
#include "protocol/robot_codec.hpp"
#include "protocol/robot_reply.hpp"
#include "sim/robot/robot_program.hpp"
#include "sim/sort_check.hpp"

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
  std::string abbRotation = "zyx";
  std::string snapshot;  // "x,y,z,qw,qx,qy,qz" mm + quaternion: send TRIG with this flange pose
  std::vector<std::string> program;  // --program files
  std::string config;                // --config: the cell the program's robot is in
  bool replyLabel = false;
  std::string checkOrder;  // best_score | by_label | label_only | random; empty = no check
  int label = 0;           // label_only: the robot's label
  std::string truthPath, journalPath;
};

// A reply checked against the dialect (protocol/robot_reply.hpp, shared with fuzz_robot_reply
// and vgr soak: vgrd's forms and ranges); the numbers are set only when valid.
struct Parsed {
  bool valid = false;
  std::string error;
  int status = 0;
  long long cycle = 0;
  double xMm = 0, yMm = 0, zMm = 0, rzDeg = 0, ryDeg = 0, rxDeg = 0;
  // The six pose numbers as the dialect carries them (ur m + rad rotation vector; abb zyx
  // mm + rz, ry, rx deg; fanuc mm + W, P, R; binary µm + millidegrees / 1000), for --program.
  // Not set for abb quaternion replies (--program refuses them).
  std::array<double, 6> values{};
  int label = 0;
  double confidence = 0;
};

double round3(double v) {
  const double r = std::round(v * 1000.0) / 1000.0;
  return r == 0.0 ? 0.0 : r;  // no -0 in the output
}

Parsed parseReply(Dialect dialect, bool abbQuaternion, const std::string& raw, bool withLabel) {
  Parsed p;
  vgr::protocol::ReplyForm form;
  form.abbRotation = abbQuaternion ? vgr::protocol::AbbRotation::Quaternion : vgr::protocol::AbbRotation::EulerZyx;
  form.withLabel = withLabel;
  const vgr::Result<vgr::protocol::ParsedReply> r = vgr::protocol::parseRobotReply(dialect, raw, form);
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
  p.ryDeg = r->ryDeg;
  p.rxDeg = r->rxDeg;
  p.values = r->values;
  p.label = r->label;
  p.confidence = r->confidence;
  return p;
}

// The flange pose as a robot program of the dialect writes it (see the top of the file).
std::string snapshotPoseText(Dialect dialect, const vgr::Pose& f) {
  switch (dialect) {
    case Dialect::Abb:
      return fmt::format("[[{:.3f},{:.3f},{:.3f}],[{:.6f},{:.6f},{:.6f},{:.6f}]]", f.x, f.y, f.z, f.qw, f.qx, f.qy, f.qz);
    case Dialect::Fanuc: {
      const vgr::EulerZyxDeg e = vgr::toEulerZyxDeg(f);
      return fmt::format("{:10.3f},{:10.3f},{:10.3f},{:10.3f},{:10.3f},{:10.3f}", f.x, f.y, f.z, e.rx, e.ry, e.rz);
    }
    default: {
      const vgr::Vec3 rv = vgr::toRotationVector(f);
      return fmt::format("p[{:.6f}, {:.6f}, {:.6f}, {:.6f}, {:.6f}, {:.6f}]", f.x / 1000.0, f.y / 1000.0, f.z / 1000.0,
                         rv.x, rv.y, rv.z);
    }
  }
}

class SimRobot {
 public:
  SimRobot(asio::io_context& io, Options opt, Dialect dialect, const std::optional<vgr::Pose>& flange,
           std::optional<vgr::sim::RobotProgram> program)
      : io_(io), opt_(std::move(opt)), dialect_(dialect), program_(std::move(program)), socket_(io), timer_(io),
        signals_(io, SIGINT, SIGTERM) {
    namespace bin = vgr::protocol::binary;
    const std::string what = flange ? "TRIG," + std::to_string(opt_.job) + "," + snapshotPoseText(dialect_, *flange)
                                    : "GET," + std::to_string(opt_.job);
    switch (dialect_) {
      case Dialect::Ur: request_ = what + "\n"; break;
      case Dialect::Fanuc: request_ = what + "\r\n"; break;
      case Dialect::Binary: request_ = bin::encodeRequest(flange ? bin::kCmdTrigger : bin::kCmdGet, opt_.job, flange); break;
      default: request_ = what + "#"; break;
    }
    if (program_) request_ = program_->request;
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
        setupLeft_ = program_ ? program_->setup.size() : 0;
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
    // A program's setup requests (RAPID: JOB,<n>#) go first on every connection.
    const std::string& request = setupLeft_ > 0 ? program_->setup[program_->setup.size() - setupLeft_] : request_;
    asio::async_write(socket_, asio::buffer(request), [this, id](const error_code& ec, std::size_t) {
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
    if (dialect_ == Dialect::Binary) {
      const std::size_t bytes = opt_.replyLabel ? vgr::protocol::binary::kLabelReplyBytes : vgr::protocol::binary::kReplyBytes;
      return rx_.size() >= bytes ? bytes : 0;
    }
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
    if (setupLeft_ > 0) {
      // The answer to a setup request: status 0 or the program stops (RAPID: Stop).
      --setupLeft_;
      const Parsed p = parseReply(dialect_, opt_.abbRotation == "quaternion", raw, opt_.replyLabel);
      if (!p.valid || p.status != 0) {
        std::cerr << "vgr-sim-robot: " << opt_.name << ": setup request refused: " << raw << "\n";
        finish(1);
        return;
      }
      exchange();
      return;
    }
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
      p = parseReply(dialect_, opt_.abbRotation == "quaternion", rawBytes, opt_.replyLabel);
    } else {
      p.error = failure;
    }
    if (p.valid) {
      ++valid_;
      if (p.status == 0) ++ok_;
      got_.push_back({p.status, static_cast<std::uint32_t>(p.cycle), p.xMm, p.yMm, p.label, p.confidence});
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
        line["ry_deg"] = p.ryDeg;
        line["rx_deg"] = p.rxDeg;
        if (opt_.replyLabel) {
          line["label"] = p.label;
          line["confidence"] = p.confidence;
        }
      } else {
        line["error"] = p.error;
      }
      line["raw"] = raw;
      if (p.valid && p.status == 0 && program_) {
        // Where the program moves the tool, and the part that picks (base frame).
        const vgr::Pose tool = program_->tcp(p.values);
        const vgr::Pose part = vgr::compose(tool, vgr::inverse(program_->grip));
        const auto e = vgr::toEulerZyxDeg(part);
        line["part_x_mm"] = part.x;
        line["part_y_mm"] = part.y;
        line["part_z_mm"] = part.z;
        line["part_rz_deg"] = e.rz;
        line["part_ry_deg"] = e.ry;
        line["part_rx_deg"] = e.rx;
      }
      std::cout << line.dump(-1, ' ', false, Json::error_handler_t::replace) << std::endl;
    } else if (p.valid) {
      std::cout << fmt::format("{} #{} valid status={} cycle={} x={:.3f} y={:.3f} z={:.3f} rz={:.3f} ry={:.3f} rx={:.3f} raw={}",
                               opt_.name, replies_, p.status, p.cycle, p.xMm, p.yMm, p.zMm, p.rzDeg, p.ryDeg, p.rxDeg, raw)
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
    bool checkFailed = false;
    if (!opt_.checkOrder.empty()) {
      Json check = orderCheck();
      checkFailed = !check.value("ok", false);
      summary["check"] = std::move(check);
    }
    std::cout << summary.dump() << std::endl;
    exitCode_ = forcedCode >= 0 ? forcedCode : ((invalid_ > 0 || checkFailed) ? 1 : 0);
    error_code ignored;
    socket_.close(ignored);
    timer_.cancel();
    signals_.cancel(ignored);
    io_.stop();
  }

  // --check-order: the replies against the truth and the journal (sim/sort_check.hpp).
  Json orderCheck() const {
    using vgr::config::PartOrder;
    const PartOrder order = opt_.checkOrder == "by_label"     ? PartOrder::ByLabel
                            : opt_.checkOrder == "label_only" ? PartOrder::LabelOnly
                            : opt_.checkOrder == "random"     ? PartOrder::Random
                                                              : PartOrder::BestScore;
    Json j;
    j["order"] = opt_.checkOrder;
    if (order == PartOrder::LabelOnly) j["label"] = opt_.label;
    auto truth = vgr::sim::readTruthFile(opt_.truthPath);
    auto journal = vgr::sim::readJournalFile(opt_.journalPath, opt_.job);
    if (!truth || !journal) {
      j["ok"] = false;
      j["problem"] = !truth ? truth.error().message : journal.error().message;
      return j;
    }
    const vgr::sim::SortCheck c = vgr::sim::checkSorting(order, opt_.label, *truth, *journal, got_);
    j["ok"] = c.ok();
    j["cycles"] = c.cycles;
    j["unseen"] = c.unseen;
    j["expected"] = c.expected;
    j["delivered"] = c.delivered;
    j["missed"] = c.missed;
    j["wrong_label"] = c.wrongLabel;
    j["extra"] = c.extra;
    j["duplicates"] = c.duplicates;
    j["out_of_order"] = c.outOfOrder;
    j["missing_no_part"] = c.missingNoPart;
    j["max_pos_err_mm"] = round3(c.maxPosErrMm);
    if (!c.firstProblem.empty()) j["problem"] = c.firstProblem;
    return j;
  }

  asio::io_context& io_;
  const Options opt_;
  const Dialect dialect_;
  const std::optional<vgr::sim::RobotProgram> program_;
  std::size_t setupLeft_ = 0;  // setup requests still to send on this connection
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
  std::vector<vgr::sim::RobotGot> got_;  // every valid reply, for --check-order
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
  app.add_option("--abb-rotation", opt.abbRotation, "abb: the reply's rotation, zyx (rz, ry, rx) or quaternion (q1..q4)")
      ->check(CLI::IsMember({"zyx", "quaternion"}));
  app.add_option("--snapshot", opt.snapshot,
                 "eye-in-hand: send TRIG,<job>,<flange pose> instead of GET; the pose as x,y,z,qw,qx,qy,qz (mm, quaternion)");
  app.add_option("--program", opt.program, "play this robot program of examples/robot/ (fanuc: vgr_bg.kl and VGR_PICK.ls)");
  app.add_option("--config", opt.config, "with --program: the cell config the robot (--name) is in");
  app.add_flag("--reply-label", opt.replyLabel, "replies carry label and confidence (the endpoint's reply_label: true)");
  auto* check = app.add_option("--check-order", opt.checkOrder,
                               "at the end, check the parts got against --truth and --journal for this part order")
                    ->check(CLI::IsMember({"best_score", "by_label", "label_only", "random"}));
  app.add_option("--label", opt.label, "label_only: the robot's label")->check(CLI::Range(0, 32767));
  app.add_option("--truth", opt.truthPath, "the camera emulator's truth.jsonl (--check-order)");
  app.add_option("--journal", opt.journalPath, "vgrd's journal (--check-order)");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  if (check->count() > 0 && (opt.truthPath.empty() || opt.journalPath.empty() || !opt.replyLabel)) {
    std::cerr << "vgr-sim-robot: --check-order needs --truth, --journal and --reply-label\n";
    return 2;
  }
  const std::optional<Dialect> dialect = vgr::protocol::parseDialect(opt.dialect);
  if (!dialect) return 2;  // unreachable: checked by CLI11
  if (opt.name.empty()) opt.name = opt.dialect;
  std::optional<vgr::Pose> flange;
  if (!opt.snapshot.empty()) {
    std::vector<double> v;
    std::string_view rest(opt.snapshot);
    while (!rest.empty()) {
      const std::size_t comma = rest.find(',');
      const std::string_view f = rest.substr(0, comma);
      double d = 0;
      const auto res = std::from_chars(f.data(), f.data() + f.size(), d);
      if (res.ec != std::errc{} || res.ptr != f.data() + f.size()) break;
      v.push_back(d);
      if (comma == std::string_view::npos) break;
      rest.remove_prefix(comma + 1);
    }
    const double n = v.size() == 7 ? std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]) : 0.0;
    if (v.size() != 7 || std::abs(n - 1.0) > 1e-3) {
      std::cerr << "vgr-sim-robot: --snapshot: expected x,y,z,qw,qx,qy,qz (mm, a unit quaternion), got '" << opt.snapshot
                << "'\n";
      return 2;
    }
    flange = vgr::poseFromQuaternion(v[0], v[1], v[2], v[3], v[4], v[5], v[6]);
  }
  std::optional<vgr::sim::RobotProgram> program;
  if (!opt.program.empty()) {
    // The example programs send their own requests (GET) and read Z-Y-X replies.
    if (flange || opt.abbRotation != "zyx") {
      std::cerr << "vgr-sim-robot: --program plays the example program's own GET and Z-Y-X replies: not with "
                   "--snapshot or --abb-rotation quaternion\n";
      return 2;
    }
    if (opt.config.empty()) {
      std::cerr << "vgr-sim-robot: --program needs --config (the cell whose robot --name it plays)\n";
      return 2;
    }
    auto cell = vgr::config::loadCellConfig(opt.config);
    if (!cell) {
      std::cerr << "vgr-sim-robot: " << cell.error().message << "\n";
      return 2;
    }
    auto p = vgr::sim::loadRobotProgram(opt.program, *dialect, *cell, opt.name);
    if (!p) {
      std::cerr << "vgr-sim-robot: " << p.error().message << "\n";
      return 2;
    }
    vgr::log::info("sim", "{}: playing {}", opt.name, p->summary);
    program = std::move(*p);
  }

  try {
    asio::io_context io;
    SimRobot robot(io, opt, *dialect, flange, std::move(program));
    robot.start();
    io.run();
    return robot.exitCode();
  } catch (const std::exception& e) {
    std::cerr << "vgr-sim-robot: " << e.what() << "\n";
    return 2;
  }
}
