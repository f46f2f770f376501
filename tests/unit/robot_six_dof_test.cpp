// Six degrees of freedom on every wire (issue 14): one tilted pose, golden bytes in every
// robot dialect (ur, abb with Z-Y-X Euler and with quaternions, fanuc, binary, strict) and
// in the Modbus registers; the eye-in-hand snapshot requests in each dialect's own pose
// notation; and requests whose pose is not a rotation. Expected values were computed
// independently (Python: R = Rz(-120) Ry(-35) Rx(170), its quaternion and rotation vector).
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <string>
#include <vector>

#include "core/cycle.hpp"
#include "core/pose.hpp"
#include "protocol/modbus_map.hpp"
#include "protocol/robot_codec.hpp"
#include "protocol/robot_strict.hpp"

namespace vgr::protocol {
namespace {

// The tilted pose: (612.5, -40.25, 455.0) mm, R = Rz(-120) Ry(-35) Rx(170).
// Quaternion (w, x, y, z) = (0.30098884, 0.45234689, -0.83590426, 0.07779508); rotation
// vector (1.20015201, -2.21779395, 0.20640336) rad.
const Pose kTilted = poseFromEulerZyxDeg(612.5, -40.25, 455.0, EulerZyxDeg{-120.0, -35.0, 170.0});

RobotReply okReply(std::uint32_t cycle, const Pose& p) {
  RobotReply r;
  r.status = Status::Ok;
  r.cycleId = cycle;
  r.pose = p;
  return r;
}

std::string bytes(std::initializer_list<int> b) {
  std::string s;
  for (int v : b) s.push_back(static_cast<char>(v));
  return s;
}

// The angle between two rotations, degrees.
double angleBetweenDeg(const Pose& a, const Pose& b) {
  const Pose d = compose(inverse(a), b);
  return 2.0 * std::acos(std::min(1.0, std::abs(d.qw))) * 180.0 / M_PI;
}

void expectPoseNear(const Pose& got, const Pose& want, double mm, double deg) {
  EXPECT_NEAR(got.x, want.x, mm);
  EXPECT_NEAR(got.y, want.y, mm);
  EXPECT_NEAR(got.z, want.z, mm);
  EXPECT_LT(angleBetweenDeg(got, want), deg);
}

TEST(robot_six_dof, TheTiltedPoseIsTheOneComputedIndependently) {
  EXPECT_NEAR(kTilted.qw, 0.30098884, 1e-8);
  EXPECT_NEAR(kTilted.qx, 0.45234689, 1e-8);
  EXPECT_NEAR(kTilted.qy, -0.83590426, 1e-8);
  EXPECT_NEAR(kTilted.qz, 0.07779508, 1e-8);
}

TEST(robot_six_dof, GoldenRepliesInEveryDialect) {
  const RobotReply r = okReply(9, kTilted);
  EXPECT_EQ(formatReply(Dialect::Ur, r), "(0,9,0.612500,-0.040250,0.455000,1.200152,-2.217794,0.206403)");
  EXPECT_EQ(formatReply(Dialect::Abb, r), "0,9,612.500,-40.250,455.000,-120.000,-35.000,170.000");
  EXPECT_EQ(formatReply(Dialect::Abb, r, false, AbbRotation::Quaternion), "0,9,612.500,-40.250,455.000,0.30099,0.45235,-0.83590,0.07780");
  EXPECT_EQ(formatReply(Dialect::Fanuc, r),
            "+0000,0000009,+00612.500,-00040.250,+00455.000,+170.000,-035.000,-120.000\r\n");
  EXPECT_EQ(formatReply(Dialect::Binary, r),
            bytes({0x56, 0x47, 0x52, 0x41, 0x00, 0x00, 0x00, 0x28, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x09,
                   0x00, 0x09, 0x58, 0x94, 0xff, 0xff, 0x62, 0xc6, 0x00, 0x06, 0xf1, 0x58, 0x00, 0x02, 0x98, 0x10,
                   0xff, 0xff, 0x77, 0x48, 0xff, 0xfe, 0x2b, 0x40}));
  const auto strict = formatStrictPoseFrame(kTilted);
  ASSERT_TRUE(strict);
  EXPECT_EQ(*strict, "(0.612500,-0.040250,0.455000,1.200152,-2.217794,0.206403)");
}

TEST(robot_six_dof, AbbQuaternionReplyStaysWithin80CharactersAndErrorsCarryTheIdentity) {
  // The longest possible Ok reply: every field at its widest.
  const Pose wide = poseFromQuaternion(-99999.999, -99999.999, -99999.999, 0.5, -0.5, -0.5, -0.5);
  const std::string worst = formatReply(Dialect::Abb, okReply(8388607, wide), false, AbbRotation::Quaternion);
  EXPECT_EQ(worst, "0,8388607,-99999.999,-99999.999,-99999.999,0.50000,-0.50000,-0.50000,-0.50000");
  EXPECT_LE(worst.size(), kAbbMaxReplyChars);
  RobotReply e = okReply(12, kTilted);
  e.status = Status::NoPartFound;
  EXPECT_EQ(formatReply(Dialect::Abb, e, false, AbbRotation::Quaternion), "1,12,0.000,0.000,0.000,1.00000,0.00000,0.00000,0.00000");
  e.status = Status::OffsetOutOfLimits;
  const std::string err = formatReply(Dialect::Abb, e, false, AbbRotation::Quaternion);
  EXPECT_EQ(err, "-9,12,0.000,0.000,0.000,1.00000,0.00000,0.00000,0.00000");
  // A quaternion stored with w < 0 is sent with q1 >= 0 (the same rotation).
  const Pose flipped{1, 2, 3, -kTilted.qw, -kTilted.qx, -kTilted.qy, -kTilted.qz};
  EXPECT_EQ(formatReply(Dialect::Abb, okReply(1, flipped), false, AbbRotation::Quaternion),
            "0,1,1.000,2.000,3.000,0.30099,0.45235,-0.83590,0.07780");
}

TEST(robot_six_dof, AbbQuaternionWithTheLabelNeverExceeds80Characters) {
  // A near pose fits with the label (config/ refuses quaternion + reply_label anyway); the
  // widest would need 88 characters and becomes -8 with zeros, never a truncated line.
  RobotReply near = okReply(9, kTilted);
  near.label = 3;
  near.confidence = 0.954;
  EXPECT_EQ(formatReply(Dialect::Abb, near, true, AbbRotation::Quaternion),
            "0,9,612.500,-40.250,455.000,0.30099,0.45235,-0.83590,0.07780,3,0.954");
  RobotReply wide = okReply(8388607, poseFromQuaternion(-99999.999, -99999.999, -99999.999, 0.5, -0.5, -0.5, -0.5));
  wide.label = 999;
  wide.confidence = 1.0;
  const std::string out = formatReply(Dialect::Abb, wide, true, AbbRotation::Quaternion);
  EXPECT_EQ(out, "-8,8388607,0.000,0.000,0.000,1.00000,0.00000,0.00000,0.00000,0,0.000");
  EXPECT_LE(out.size(), kAbbMaxReplyChars);
}

TEST(robot_six_dof, ModbusRegistersCarryAllSixFloatsAndTheirMirrors) {
  CycleResult c;
  c.cycleId = 9;
  c.status = Status::Ok;
  c.jobId = 1;
  PartResult part;
  part.pose = poseFromEulerZyxDeg(-250.0, 1000.5, -5.25, EulerZyxDeg{30.0, 20.0, 10.0});
  part.score = 0.5;
  c.parts.push_back(part);
  const ModbusResult m = modbusResultFrom(c);
  ModbusMap map;
  map.setReady(true);
  ASSERT_TRUE(map.publishResult(m));
  // X, Y, Z, R1 = rx, R2 = ry, R3 = rz: float32 high word first (Python struct '>f').
  const std::uint16_t expected[12] = {0xc37a, 0x0000, 0x447a, 0x2000, 0xc0a8, 0x0000,
                                      0x4120, 0x0000, 0x41a0, 0x0000, 0x41f0, 0x0000};
  for (std::uint16_t i = 0; i < 12; ++i) EXPECT_EQ(map.input(static_cast<std::uint16_t>(modbus::kX + i)), expected[i]) << "register " << 24 + i;
  // int16 mirrors: 0.1 mm and 0.01 degree.
  EXPECT_EQ(static_cast<std::int16_t>(map.input(modbus::kXInt)), -2500);
  EXPECT_EQ(static_cast<std::int16_t>(map.input(modbus::kXInt + 1)), 10005);
  EXPECT_EQ(static_cast<std::int16_t>(map.input(modbus::kXInt + 2)), -53);  // -52.5 rounds away from zero
  EXPECT_EQ(static_cast<std::int16_t>(map.input(modbus::kR1Int)), 1000);
  EXPECT_EQ(static_cast<std::int16_t>(map.input(modbus::kR1Int + 1)), 2000);
  EXPECT_EQ(static_cast<std::int16_t>(map.input(modbus::kR1Int + 2)), 3000);
}

// ---- eye-in-hand snapshot requests --------------------------------------------------------

TEST(robot_snapshot, EachDialectReadsItsOwnPoseNotation) {
  struct Case {
    Dialect dialect;
    std::string line;
    double mm, deg;  // what the notation's precision allows
  };
  const std::vector<Case> cases = {
      // URScript prints a pose with 4 decimals.
      {Dialect::Ur, "TRIG,3,p[0.6125, -0.0402, 0.4550, 1.2002, -2.2178, 0.2064]", 0.06, 0.01},
      {Dialect::Ur, "TRIG,3,0.612500,-0.040250,0.455000,1.200152,-2.217794,0.206403", 1e-3, 1e-4},
      // RAPID ValToStr of a pose (6 significant digits), and plain quaternion / Z-Y-X.
      {Dialect::Abb, "TRIG,3,[[612.5,-40.25,455],[0.300989,0.452347,-0.835904,0.077795]]", 1e-3, 1e-3},
      {Dialect::Abb, "TRIG,3,612.5,-40.25,455,0.30098884,0.45234689,-0.83590426,0.07779508", 1e-6, 1e-5},
      {Dialect::Abb, "TRIG,3,612.500,-40.250,455.000,-120.000,-35.000,170.000", 1e-6, 1e-6},
      // KAREL's WRITE x::10::3 pads with spaces.
      {Dialect::Fanuc, "TRIG,3,   612.500,   -40.250,   455.000,   170.000,   -35.000,  -120.000", 1e-6, 1e-6},
      // GET with a pose is a snapshot too.
      {Dialect::Fanuc, "GET,3,612.5,-40.25,455,170,-35,-120", 1e-6, 1e-6},
  };
  for (const Case& c : cases) {
    const auto r = parseRequest(c.line, c.dialect);
    ASSERT_TRUE(r) << c.line << ": " << r.error().message;
    EXPECT_EQ(r->command, Command::Trigger) << c.line;
    EXPECT_EQ(r->job, 3);
    ASSERT_TRUE(r->flange.has_value()) << c.line;
    expectPoseNear(*r->flange, kTilted, c.mm, c.deg);
  }
  // Requests without a pose are unchanged.
  const auto last = parseRequest("GET,3,LAST", Dialect::Abb);
  ASSERT_TRUE(last);
  EXPECT_TRUE(last->last);
  EXPECT_FALSE(last->flange);
  const auto trig = parseRequest("TRIG,3", Dialect::Ur);
  ASSERT_TRUE(trig);
  EXPECT_FALSE(trig->flange);
}

TEST(robot_snapshot, APoseThatIsNotARotationIsBadArgument) {
  const std::vector<std::pair<Dialect, std::string>> bad = {
      {Dialect::Abb, "TRIG,1,612.5,-40.25,455,0.9,0,0,0"},           // |q| = 0.9
      {Dialect::Abb, "TRIG,1,[[612.5,-40.25,455],[0,0,0,0]]"},       // zero quaternion
      {Dialect::Abb, "TRIG,1,[[612.5,-40.25],[1,0,0,0]]"},           // two coordinates
      {Dialect::Abb, "TRIG,1,612.5,-40.25,455,400,0,0"},             // Euler angle beyond 360
      {Dialect::Ur, "TRIG,1,p[0.6, 0, 0.4, 7.0, 0, 0]"},             // rotation vector > 2 pi
      {Dialect::Ur, "TRIG,1,0.6,0,0.4,nan,0,0"},                     // not finite
      {Dialect::Ur, "TRIG,1,0.6,0,0.4,inf,0,0"},
      {Dialect::Ur, "TRIG,1,0.6,0,0.4,0,0"},                         // five numbers
      {Dialect::Ur, "TRIG,1,p[0.6, 0, 0.4, 0, 0, 0"},                // no closing bracket
      {Dialect::Fanuc, "TRIG,1,612.5,-40.25,455,170,-35,abc"},       // not a number
      {Dialect::Fanuc, "TRIG,1,100000,0,0,0,0,0"},                   // beyond +-99999.999 mm
      {Dialect::Fanuc, "GET,1,FOO"},                                 // neither LAST nor a pose
      {Dialect::Abb, "TRIG,,612.5,-40.25,455,-120,-35,170"},         // no job
  };
  for (const auto& [dialect, line] : bad) {
    const auto r = parseRequest(line, dialect);
    ASSERT_FALSE(r) << line;
    EXPECT_EQ(r.error().code, Status::BadArgument) << line << ": " << r.error().message;
  }
  const auto q = parseRequest("TRIG,1,612.5,-40.25,455,0.9,0,0,0", Dialect::Abb);
  EXPECT_NE(q.error().message.find("not a rotation"), std::string::npos) << q.error().message;
  EXPECT_EQ(parseRequest("JOB,1,0,0,0,0,0,0", Dialect::Fanuc).error().code, Status::BadArgument);
}

TEST(robot_snapshot, BinaryFortyByteRequestCarriesThePose) {
  // Golden: TRIG (4), job 3, the tilted pose in µm and millidegrees (W, P, R).
  const std::string frame = binary::encodeRequest(binary::kCmdTrigger, 3, kTilted);
  EXPECT_EQ(frame, bytes({0x56, 0x47, 0x52, 0x51, 0x00, 0x00, 0x00, 0x28, 0x00, 0x00, 0x00, 0x04, 0x00, 0x00, 0x00, 0x03,
                          0x00, 0x09, 0x58, 0x94, 0xff, 0xff, 0x62, 0xc6, 0x00, 0x06, 0xf1, 0x58, 0x00, 0x02, 0x98, 0x10,
                          0xff, 0xff, 0x77, 0x48, 0xff, 0xfe, 0x2b, 0x40}));
  RequestDecoder d(Dialect::Binary);
  // A pose frame between two plain ones, delivered a byte at a time.
  const std::string stream = binary::encodeRequest(binary::kCmdGet, 1) + frame + binary::encodeRequest(binary::kCmdGet, 2);
  std::vector<Result<RobotRequest>> got;
  for (char c : stream) {
    d.append(std::string(1, c));
    while (auto r = d.next()) got.push_back(*r);
  }
  ASSERT_EQ(got.size(), 3u);
  ASSERT_TRUE(got[1]);
  EXPECT_EQ(got[1]->command, Command::Trigger);
  EXPECT_EQ(got[1]->job, 3);
  ASSERT_TRUE(got[1]->flange);
  expectPoseNear(*got[1]->flange, kTilted, 1e-9, 1e-3);
  ASSERT_TRUE(got[0] && got[2]);
  EXPECT_FALSE(got[0]->flange);
  EXPECT_EQ(got[2]->job, 2);

  // JOB with a pose, and angles beyond 360 degrees: -2, the frame skipped, in step after.
  std::string job = binary::encodeRequest(binary::kCmdJob, 3, kTilted);
  std::string wild = frame;
  wild[28] = 0x7f;  // w = 2.1e9 millidegrees
  d.append(job + wild + binary::encodeRequest(binary::kCmdGet, 5));
  std::vector<Result<RobotRequest>> more;
  while (auto r = d.next()) more.push_back(*r);
  ASSERT_EQ(more.size(), 3u);
  EXPECT_EQ(more[0].error().code, Status::BadArgument);
  EXPECT_EQ(more[1].error().code, Status::BadArgument);
  ASSERT_TRUE(more[2]);
  EXPECT_EQ(more[2]->job, 5);
}

TEST(robot_snapshot, StrictSnapshotTriggersThenPushesOrAnswersNone) {
  StrictTokens t;
  t.snapshot = "MoveJ_snapshot";
  StrictExchange ex(t);
  ASSERT_TRUE(ex.snapshotMode());
  // Arrives in pieces, with URScript's printed pose.
  ex.feed("MoveJ_snap");
  EXPECT_EQ(ex.poll().kind, StrictExchange::EventKind::None);
  ex.feed("shotp[0.6125, -0.0402, 0.4550, ");
  EXPECT_EQ(ex.poll().kind, StrictExchange::EventKind::None);
  ex.feed("1.2002, -2.2178, 0.2064]");
  auto e = ex.poll();
  ASSERT_EQ(e.kind, StrictExchange::EventKind::Snapshot);
  expectPoseNear(e.pose, kTilted, 0.06, 0.01);
  EXPECT_EQ(ex.step(), StrictExchange::Step::AwaitResult);
  // The cycle found nothing: "MoveJ_none(1)", back to waiting for the next snapshot.
  EXPECT_EQ(ex.noResult(Status::NoPartFound), "MoveJ_none(1)");
  EXPECT_EQ(ex.step(), StrictExchange::Step::Idle);
  // The next one with the frame notation finds a part: the four steps as usual.
  ex.feed("MoveJ_snapshot(0.612500,-0.040250,0.455000,1.200152,-2.217794,0.206403)");
  ASSERT_EQ(ex.poll().kind, StrictExchange::EventKind::Snapshot);
  EXPECT_EQ(ex.begin("(0.1,0.2,0.3,0,0,0)"), "MoveJ_pose");
  ex.feed("MoveJ_pose_wait_pos");
  e = ex.poll();
  ASSERT_EQ(e.kind, StrictExchange::EventKind::SendPose);
  EXPECT_EQ(e.bytes, "(0.1,0.2,0.3,0,0,0)");
  ex.feed("MoveJ_pose_done");
  EXPECT_EQ(ex.poll().kind, StrictExchange::EventKind::Completed);
  // A pose that is not one: BadSnapshot with -2, still idle.
  ex.feed("MoveJ_snapshot(0.6,0,0.4,9,0,0)");
  e = ex.poll();
  ASSERT_EQ(e.kind, StrictExchange::EventKind::BadSnapshot);
  EXPECT_EQ(e.status, Status::BadArgument);
  EXPECT_EQ(ex.noResult(e.status), "MoveJ_none(-2)");
  // Something else entirely while idle: unexpected, discarded.
  ex.feed("hello");
  EXPECT_EQ(ex.poll().kind, StrictExchange::EventKind::Unexpected);
}

}  // namespace
}  // namespace vgr::protocol
