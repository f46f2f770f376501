// The robot programs in examples/robot/ against a real vgrd robot server (RobotServer +
// ResultStore on one I/O thread, raw TCP on loopback): the request each program sends is
// read out of the program file, and the reply is parsed with a re-implementation of that
// language's rules. The parsed values must give back the published pose, to the precision
// of the language's number type (RAPID num and KAREL REAL are 32-bit floats).
//   RAPID   : SocketReceive \Str (one receive, at most 80 characters), StrFind / StrPart /
//             StrToVal as ParseReply in VgrPick.mod does.
//   KAREL   : READ up to the line end into STRING[254]; SUB_STR at the columns written in
//             vgr_bg.kl; CNV_STR_INT / CNV_STR_REAL.
//   URScript: socket_read_ascii_float(n): "(v1,...,vn)" exactly, else [0].
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <gtest/gtest.h>

#include <cmath>
#include <fstream>
#include <functional>
#include <memory>
#include <mutex>
#include <thread>
#include <optional>
#include <regex>
#include <sstream>
#include <string>
#include <vector>

#include <boost/asio/io_context.hpp>

#include "daemon/result_store.hpp"
#include "protocol/robot_server.hpp"
#include "tests/support/io_thread.hpp"
#include "tests/support/raw_tcp_client.hpp"

namespace vgr::protocol {
namespace {

namespace asio = boost::asio;
using namespace std::chrono_literals;
using Clock = std::chrono::steady_clock;
constexpr double kPi = 3.14159265358979323846;

std::string example(const std::string& name) {
  std::ifstream in(std::string(VGR_SOURCE_DIR) + "/examples/robot/" + name);
  std::stringstream ss;
  ss << in.rdbuf();
  return ss.str();
}

// A robot program's socket; reads wait up to 3 s.
class Socket : public test::RawTcpClient {
 public:
  explicit Socket(std::uint16_t port) : RawTcpClient(port, {.readTimeout = 3000ms}) {}
  void send(const std::string& s) { ASSERT_TRUE(RawTcpClient::send(s)); }
  // One recv of at most `max` bytes (what a single SocketReceive / read call returns).
  std::string recvOnce(std::size_t max) { return readOnce(max).value_or(""); }
  // Up to and including `stop` (or `limit` bytes).
  std::string recvUntil(char stop, std::size_t limit) { return readUntil(stop, kDefault, limit).value_or(""); }
};

// ---- RAPID -------------------------------------------------------------------------------

// StrFind(Str, ChPos, Set): first position >= ChPos holding a character of Set, else
// StrLen(Str) + 1 (1-based).
int rapidStrFind(const std::string& s, int chPos, const std::string& set) {
  for (int i = chPos; i <= static_cast<int>(s.size()); ++i)
    if (set.find(s[static_cast<std::size_t>(i - 1)]) != std::string::npos) return i;
  return static_cast<int>(s.size()) + 1;
}
std::string rapidStrPart(const std::string& s, int chPos, int len) {
  return s.substr(static_cast<std::size_t>(chPos - 1), static_cast<std::size_t>(len));
}
// StrToVal into a num (32-bit float): a decimal number, optional '-', optional fraction.
bool rapidStrToVal(const std::string& s, float& out) {
  static const std::regex kNum(R"(-?\d+(\.\d+)?)");
  if (!std::regex_match(s, kNum)) return false;
  out = std::stof(s);
  return true;
}
// ParseReply of VgrPick.mod.
std::optional<std::vector<float>> rapidParseReply(const std::string& s) {
  std::vector<float> vals(8);
  int start = 1;
  for (int i = 0; i < 8; ++i) {
    const int comma = rapidStrFind(s, start, ",");
    if (!rapidStrToVal(rapidStrPart(s, start, comma - start), vals[static_cast<std::size_t>(i)])) return std::nullopt;
    start = comma + 1;
  }
  return vals;
}

// ---- KAREL -------------------------------------------------------------------------------

// READ f(str) into STRING[254]: up to the line end (LF; a CR before it is dropped).
std::optional<std::string> karelReadLine(Socket& s) {
  std::string line = s.recvUntil('\n', 255);
  if (line.empty() || line.back() != '\n') return std::nullopt;  // no line end within 254
  line.pop_back();
  if (!line.empty() && line.back() == '\r') line.pop_back();
  if (line.size() > 254) return std::nullopt;
  return line;
}
std::string karelSubStr(const std::string& s, int start, int len) {
  if (start < 1 || start > static_cast<int>(s.size())) return {};
  return s.substr(static_cast<std::size_t>(start - 1), static_cast<std::size_t>(len));
}
// CNV_STR_INT / CNV_STR_REAL: optional sign, digits, (REAL) optional fraction; anything
// else leaves the target uninitialised, which we report as nullopt.
std::optional<long> karelCnvStrInt(const std::string& s) {
  if (!std::regex_match(s, std::regex(R"([+-]?\d+)"))) return std::nullopt;
  return std::stol(s);
}
std::optional<float> karelCnvStrReal(const std::string& s) {
  if (!std::regex_match(s, std::regex(R"([+-]?\d+(\.\d+)?)"))) return std::nullopt;
  return std::stof(s);
}

// ---- URScript ----------------------------------------------------------------------------

// socket_read_ascii_float(n): reads up to ')' and returns [n, v1..vn] for exactly
// "(v1,...,vn)", [0] otherwise.
std::vector<double> urReadAsciiFloat(Socket& s, int n) {
  const std::string raw = s.recvUntil(')', 1024);
  static const std::regex kNum(R"(\s*[+-]?\d+(\.\d+)?\s*)");
  if (raw.size() < 2 || raw.front() != '(' || raw.back() != ')') return {0};
  std::vector<double> out{0};
  std::string body = raw.substr(1, raw.size() - 2);
  std::size_t pos = 0;
  for (;;) {
    const std::size_t comma = body.find(',', pos);
    const std::string field = body.substr(pos, comma - pos);
    if (!std::regex_match(field, kNum)) return {0};
    out.push_back(std::stod(field));
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  if (static_cast<int>(out.size()) - 1 != n || n > 30) return {0};
  out[0] = n;
  return out;
}

// ---- the server ------------------------------------------------------------------------

class robot_languages : public ::testing::Test {
 protected:
  void SetUp() override {
    store_ = std::make_unique<daemon::ResultStore>(io_, std::set<int>{1});
    // Eye-in-hand snapshots: record the flange pose, hand out cycle ids.
    store_->setTrigger([this](int, const std::optional<Pose>& flange) {
      std::lock_guard lock(flangeMutex_);
      flanges_.push_back(flange);
      return static_cast<std::uint32_t>(100 + flanges_.size());
    });
    for (Dialect d : {Dialect::Abb, Dialect::Fanuc, Dialect::Ur, Dialect::Strict, Dialect::Strict}) {
      RobotEndpoint ep;
      ep.name = std::string(dialectName(d)) + (servers_.size() == 4 ? "-snapshot" : "");
      ep.dialect = d;
      if (servers_.size() == 4) ep.strict.snapshot = "MoveJ_snapshot";  // vgr_strict_snapshot.script
      store_->addRobot(ep.name, daemon::RobotPolicy{1, 1500, daemon::PartOrder::BestScore, 0});
      servers_.push_back(std::make_unique<RobotServer>(io_, ep, [this](const std::string& robot, const RobotRequest& req, ReplyFn reply) {
        store_->handle(robot, req, std::move(reply));
      }));
      ASSERT_TRUE(servers_.back()->start());
    }
    ioThread_.start();
  }
  void TearDown() override {
    onIo([this] {
      for (auto& s : servers_) s->stop();
    });
    ioThread_.stop();
  }
  void onIo(const std::function<void()>& f) { ioThread_.run(f); }
  std::uint16_t port(Dialect d) { return servers_[static_cast<std::size_t>(d == Dialect::Abb ? 0 : d == Dialect::Fanuc ? 1 : d == Dialect::Ur ? 2 : 3)]->port(); }
  std::uint16_t snapshotStrictPort() { return servers_[4]->port(); }

  // The flange pose of the next snapshot the store triggers (waits up to 3 s), and the
  // cycle id it got.
  std::optional<std::pair<std::uint32_t, Pose>> nextSnapshot() {
    const auto deadline = Clock::now() + 3s;
    while (Clock::now() < deadline) {
      {
        std::lock_guard lock(flangeMutex_);
        if (flanges_.size() > seen_) {
          ++seen_;
          if (!flanges_[seen_ - 1]) return std::nullopt;
          return std::make_pair(static_cast<std::uint32_t>(100 + seen_), *flanges_[seen_ - 1]);
        }
      }
      std::this_thread::sleep_for(5ms);
    }
    return std::nullopt;
  }

  // A pose at the edge of what the wire carries, with a tilt, and a large cycle id.
  void publish(std::uint32_t cycle, const Pose& p) {
    CycleResult r;
    r.cycleId = cycle;
    r.jobId = 1;
    r.status = Status::Ok;
    PartResult part;
    part.pose = p;
    r.parts.push_back(part);
    onIo([&] { store_->onResult(r); });
  }

  vgr::test::IoThread ioThread_;
  asio::io_context& io_ = ioThread_.io();
  std::unique_ptr<daemon::ResultStore> store_;
  std::vector<std::unique_ptr<RobotServer>> servers_;
  std::mutex flangeMutex_;
  std::vector<std::optional<Pose>> flanges_;
  std::size_t seen_ = 0;
};

// The angle between two rotations, degrees.
double angleBetweenDeg(const Pose& a, const Pose& b) {
  const double dot = std::abs(a.qw * b.qw + a.qx * b.qx + a.qy * b.qy + a.qz * b.qz);
  return 2.0 * std::acos(std::min(1.0, dot)) * 180.0 / kPi;
}

// R = Rz(rz) Ry(ry) Rx(rx) as a unit quaternion (w, x, y, z), written out.
Pose poseZyxDeg(double x, double y, double z, double rz, double ry, double rx) {
  const double cz = std::cos(rz * kPi / 360), sz = std::sin(rz * kPi / 360);
  const double cy = std::cos(ry * kPi / 360), sy = std::sin(ry * kPi / 360);
  const double cx = std::cos(rx * kPi / 360), sx = std::sin(rx * kPi / 360);
  return Pose{x, y, z, cz * cy * cx + sz * sy * sx, cz * cy * sx - sz * sy * cx, cz * sy * cx + sz * cy * sx,
              sz * cy * cx - cz * sy * sx};
}

struct Case {
  std::uint32_t cycle;
  double x, y, z, rz, ry, rx;
};
const std::vector<Case> kCases = {
    {4711, 512.3, -120.05, 35.0, -12.5, 0.0, 0.0},
    {8388607, -99999.999, 99999.999, -99999.999, -179.999, -45.5, 179.999},
    {1, -0.001, 0.0, 1234.5, 90.0, 30.0, -60.0},
};

TEST_F(robot_languages, RapidModuleParsesEveryReply) {
  const std::string mod = example("VgrPick.mod");
  // The requests in program order: JOB,<n># once, then GET# (the current job).
  std::vector<std::string> sends;
  const std::regex send(R"re(SocketSend sock \\Str:="([^"]*)")re");
  for (auto it = std::sregex_iterator(mod.begin(), mod.end(), send); it != std::sregex_iterator(); ++it) sends.push_back((*it)[1]);
  ASSERT_EQ(sends, (std::vector<std::string>{"JOB,1#", "GET#"}));
  const std::string request = sends[1];
  ASSERT_NE(mod.find("FOR i FROM 1 TO 8"), std::string::npos);
  ASSERT_NE(mod.find("OrientZYX(vals{6}, vals{7}, vals{8})"), std::string::npos);

  Socket s(port(Dialect::Abb));
  s.send(sends[0]);
  const auto job = rapidParseReply(s.recvOnce(80));
  ASSERT_TRUE(job);
  EXPECT_EQ((*job)[0], 0.0f);  // JOB,1: status 0, so the program goes on
  for (const Case& c : kCases) {
    publish(c.cycle, poseZyxDeg(c.x, c.y, c.z, c.rz, c.ry, c.rx));
    s.send(request);
    const std::string reply = s.recvOnce(80);  // SocketReceive \Str: one receive, <= 80 chars
    ASSERT_LE(reply.size(), 80u);
    const auto vals = rapidParseReply(reply);
    ASSERT_TRUE(vals) << reply;
    EXPECT_EQ((*vals)[0], 0.0f);
    EXPECT_EQ((*vals)[1], static_cast<float>(c.cycle));  // exact: below 2^23
    EXPECT_EQ((*vals)[2], static_cast<float>(c.x)) << reply;
    EXPECT_EQ((*vals)[3], static_cast<float>(c.y)) << reply;
    EXPECT_EQ((*vals)[4], static_cast<float>(c.z)) << reply;
    EXPECT_NEAR((*vals)[5], c.rz, 1e-3);  // OrientZYX(rz, ry, rx)
    EXPECT_NEAR((*vals)[6], c.ry, 1e-3);
    EXPECT_NEAR((*vals)[7], c.rx, 1e-3);
  }
}

TEST_F(robot_languages, KarelTaskParsesFixedColumns) {
  const std::string kl = example("vgr_bg.kl");
  // The columns the KAREL program reads, in its order: status, cycle, x, y, z, w, p, r.
  std::vector<std::pair<int, int>> cols;
  const std::regex kSub(R"(SUB_STR\(reply, (\d+), (\d+)\))");
  for (auto it = std::sregex_iterator(kl.begin(), kl.end(), kSub); it != std::sregex_iterator(); ++it)
    cols.emplace_back(std::stoi((*it)[1].str()), std::stoi((*it)[2].str()));
  ASSERT_EQ(cols.size(), 8u);
  ASSERT_NE(kl.find("WRITE sock('GET,', JOB_NO::1, CR)"), std::string::npos);

  Socket s(port(Dialect::Fanuc));
  for (const Case& c : kCases) {
    publish(c.cycle, poseZyxDeg(c.x, c.y, c.z, c.rz, c.ry, c.rx));
    s.send("GET,1\r");  // WRITE sock('GET,', 1, CR)
    const auto line = karelReadLine(s);
    ASSERT_TRUE(line);
    ASSERT_LT(line->size(), 254u);
    const auto status = karelCnvStrInt(karelSubStr(*line, cols[0].first, cols[0].second));
    const auto cycle = karelCnvStrInt(karelSubStr(*line, cols[1].first, cols[1].second));
    ASSERT_TRUE(status && cycle) << *line;
    EXPECT_EQ(*status, 0);
    EXPECT_EQ(*cycle, static_cast<long>(c.cycle));
    std::vector<float> v;
    for (std::size_t i = 2; i < 8; ++i) {
      const auto f = karelCnvStrReal(karelSubStr(*line, cols[i].first, cols[i].second));
      ASSERT_TRUE(f) << *line << " field " << i;
      v.push_back(*f);
    }
    EXPECT_EQ(v[0], static_cast<float>(c.x)) << *line;
    EXPECT_EQ(v[1], static_cast<float>(c.y)) << *line;
    EXPECT_EQ(v[2], static_cast<float>(c.z)) << *line;
    EXPECT_NEAR(v[3], c.rx, 1e-3);  // W
    EXPECT_NEAR(v[4], c.ry, 1e-3);  // P
    EXPECT_NEAR(v[5], c.rz, 1e-3);  // R
  }
}

TEST_F(robot_languages, UrScriptReadsEightFloats) {
  const std::string script = example("vgr_pick.script");
  std::smatch m;
  ASSERT_TRUE(std::regex_search(script, m, std::regex(R"re(socket_send_line\("([^"]*)")re")));
  ASSERT_NE(script.find("socket_read_ascii_float(8"), std::string::npos);
  const std::string request = m[1].str() + "\n";  // socket_send_line adds the newline

  Socket s(port(Dialect::Ur));
  for (const Case& c : kCases) {
    const Pose p = poseZyxDeg(c.x, c.y, c.z, c.rz, c.ry, c.rx);
    publish(c.cycle, p);
    s.send(request);
    const std::vector<double> r = urReadAsciiFloat(s, 8);
    ASSERT_EQ(r[0], 8);
    EXPECT_EQ(r[1], 0);
    EXPECT_EQ(r[2], c.cycle);
    EXPECT_NEAR(r[3] * 1000, c.x, 1e-3);
    EXPECT_NEAR(r[4] * 1000, c.y, 1e-3);
    EXPECT_NEAR(r[5] * 1000, c.z, 1e-3);
    // Rotation vector: |v| = angle, v / |v| = axis, against the quaternion.
    const double angle = std::sqrt(r[6] * r[6] + r[7] * r[7] + r[8] * r[8]);
    const double w = std::cos(angle / 2), k = angle > 1e-12 ? std::sin(angle / 2) / angle : 0.5;
    const double dot = std::abs(w * p.qw + k * (r[6] * p.qx + r[7] * p.qy + r[8] * p.qz));
    EXPECT_NEAR(dot, 1.0, 1e-9);
  }
}

TEST_F(robot_languages, UrStrictScriptHandshake) {
  const std::string script = example("vgr_strict.script");
  for (const char* needle : {"cmd == \"MoveJ_pose\"", "socket_send_string(\"MoveJ_pose_wait_pos\"",
                             "socket_read_ascii_float(6", "socket_send_string(\"MoveJ_pose_done\""})
    ASSERT_NE(script.find(needle), std::string::npos) << needle;

  Socket s(port(Dialect::Strict));
  const Case& c = kCases[1];
  publish(c.cycle, poseZyxDeg(c.x, c.y, c.z, c.rz, c.ry, c.rx));
  EXPECT_EQ(s.recvOnce(64), "MoveJ_pose");  // socket_read_string: what is there
  s.send("MoveJ_pose_wait_pos");
  const std::vector<double> v = urReadAsciiFloat(s, 6);
  ASSERT_EQ(v[0], 6);
  EXPECT_NEAR(v[1] * 1000, c.x, 1e-3);
  EXPECT_NEAR(v[2] * 1000, c.y, 1e-3);
  EXPECT_NEAR(v[3] * 1000, c.z, 1e-3);
  s.send("MoveJ_pose_done");
}

// ---- eye-in-hand snapshots (the flange pose goes with the request) --------------------------

// The flange pose of the examples below, a tilted one.
const Pose kFlange = poseZyxDeg(612.5, -40.25, 455.0, -120.0, -35.0, 170.0);

TEST_F(robot_languages, UrSnapshotScriptSendsTheFlangePose) {
  const std::string script = example("vgr_snapshot.script");
  for (const char* needle : {"socket_send_string(\"TRIG,1,\"", "socket_send_string(get_actual_tool_flange_pose()",
                             "socket_send_line(\"\"", "socket_read_ascii_float(8"})
    ASSERT_NE(script.find(needle), std::string::npos) << needle;
  Socket s(port(Dialect::Ur));
  // What the three sends put on the wire: URScript prints a pose with 4 decimals.
  s.send("TRIG,1,");
  s.send("p[0.6125, -0.0402, 0.4550, 1.2002, -2.2178, 0.2064]");
  s.send("\n");
  const auto snap = nextSnapshot();
  ASSERT_TRUE(snap);
  EXPECT_NEAR(snap->second.x, kFlange.x, 0.06);
  EXPECT_NEAR(snap->second.y, kFlange.y, 0.06);
  EXPECT_NEAR(snap->second.z, kFlange.z, 0.06);
  EXPECT_LT(angleBetweenDeg(snap->second, kFlange), 0.01);
  const Pose part = poseZyxDeg(300.0, 20.0, 5.0, 45.0, 10.0, -5.0);
  publish(snap->first, part);
  const std::vector<double> r = urReadAsciiFloat(s, 8);
  ASSERT_EQ(r[0], 8);
  EXPECT_EQ(r[1], 0);
  EXPECT_EQ(r[2], snap->first);
  EXPECT_NEAR(r[3] * 1000, part.x, 1e-3);
}

TEST_F(robot_languages, RapidSnapshotSendsValToStrOfThePose) {
  const std::string mod = example("VgrSnapshot.mod");
  for (const char* needle : {"SocketSend sock \\Str:=\"TRIG,1,\";", "SocketSend sock \\Str:=ValToStr(flange);",
                             "SocketSend sock \\Str:=\"#\";", "CRobT(\\Tool:=tool0 \\WObj:=wobj0)"})
    ASSERT_NE(mod.find(needle), std::string::npos) << needle;
  Socket s(port(Dialect::Abb));
  // ValToStr of a pose: 6 significant digits per num, as RAPID writes them.
  s.send("TRIG,1,");
  s.send("[[612.5,-40.25,455],[0.300989,0.452347,-0.835904,0.0777951]]");
  s.send("#");
  const auto snap = nextSnapshot();
  ASSERT_TRUE(snap);
  EXPECT_NEAR(snap->second.x, kFlange.x, 1e-3);
  EXPECT_NEAR(snap->second.z, kFlange.z, 1e-3);
  EXPECT_LT(angleBetweenDeg(snap->second, kFlange), 1e-3);
  publish(snap->first, poseZyxDeg(300.0, 20.0, 5.0, 45.0, 10.0, -5.0));
  const auto vals = rapidParseReply(s.recvOnce(80));
  ASSERT_TRUE(vals);
  EXPECT_EQ((*vals)[0], 0.0f);
  EXPECT_EQ((*vals)[1], static_cast<float>(snap->first));
  EXPECT_NEAR((*vals)[5], 45.0, 1e-3);
  EXPECT_NEAR((*vals)[6], 10.0, 1e-3);
  EXPECT_NEAR((*vals)[7], -5.0, 1e-3);
}

TEST_F(robot_languages, KarelSnapshotWritesTheFlangeWpr) {
  const std::string kl = example("vgr_snap.kl");
  ASSERT_NE(kl.find("WRITE sock('TRIG,', JOB_NO::1, ',', here.x::10::3"), std::string::npos);
  ASSERT_NE(kl.find("here.w::10::3, ',', here.p::10::3, ',', here.r::10::3, CR)"), std::string::npos);
  Socket s(port(Dialect::Fanuc));
  // WRITE x::10::3: right-aligned in 10 characters, 3 decimals (W = rx, P = ry, R = rz).
  s.send("TRIG,1,   612.500,   -40.250,   455.000,   170.000,   -35.000,  -120.000\r");
  const auto snap = nextSnapshot();
  ASSERT_TRUE(snap);
  EXPECT_NEAR(snap->second.y, kFlange.y, 1e-6);
  EXPECT_LT(angleBetweenDeg(snap->second, kFlange), 1e-4);
  publish(snap->first, poseZyxDeg(300.0, 20.0, 5.0, 45.0, 10.0, -5.0));
  const auto line = karelReadLine(s);
  ASSERT_TRUE(line);
  EXPECT_EQ(karelCnvStrInt(karelSubStr(*line, 1, 5)), 0);
  EXPECT_EQ(karelCnvStrReal(karelSubStr(*line, 48, 8)), -5.0f);  // W
}

TEST_F(robot_languages, UrStrictSnapshotScriptHandshake) {
  const std::string script = example("vgr_strict_snapshot.script");
  for (const char* needle : {"socket_send_string(\"MoveJ_snapshot\"", "socket_send_string(get_actual_tool_flange_pose()",
                             "cmd == \"MoveJ_pose\"", "socket_send_string(\"MoveJ_pose_done\""})
    ASSERT_NE(script.find(needle), std::string::npos) << needle;
  Socket s(snapshotStrictPort());
  EXPECT_TRUE(s.quiet(200ms));  // snapshot mode: vgrd waits for the robot
  s.send("MoveJ_snapshot");
  s.send("p[0.6125, -0.0402, 0.4550, 1.2002, -2.2178, 0.2064]");
  auto snap = nextSnapshot();
  ASSERT_TRUE(snap);
  EXPECT_LT(angleBetweenDeg(snap->second, kFlange), 0.01);
  publish(snap->first, poseZyxDeg(300.0, 20.0, 5.0, 45.0, 10.0, -5.0));
  EXPECT_EQ(s.recvOnce(64), "MoveJ_pose");
  s.send("MoveJ_pose_wait_pos");
  const std::vector<double> v = urReadAsciiFloat(s, 6);
  ASSERT_EQ(v[0], 6);
  EXPECT_NEAR(v[1] * 1000, 300.0, 1e-3);
  s.send("MoveJ_pose_done");
  // The next view has no part: "MoveJ_none(1)".
  s.send("MoveJ_snapshot(0.612500,-0.040250,0.455000,1.200152,-2.217794,0.206403)");
  snap = nextSnapshot();
  ASSERT_TRUE(snap);
  CycleResult empty;
  empty.cycleId = snap->first;
  empty.jobId = 1;
  empty.status = Status::NoPartFound;
  onIo([&] { store_->onResult(empty); });
  EXPECT_EQ(s.recvOnce(64), "MoveJ_none(1)");
}

}  // namespace
}  // namespace vgr::protocol
