// Golden bytes for the fanuc and binary dialects, the binary request decoder, the strict
// pose frame, and the length promises (FANUC fixed columns under 254, ABB <= 80) over the
// whole position range a cell can report (protocol/robot_codec.hpp).
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include <Eigen/Geometry>

#include "protocol/robot_codec.hpp"

namespace vgr::protocol {
namespace {

constexpr double kPi = 3.14159265358979323846;
double deg(double d) { return d * kPi / 180.0; }

const std::regex kFanucRegex(
    R"([+-]\d{4},\d{7},[+-]\d{5}\.\d{3},[+-]\d{5}\.\d{3},[+-]\d{5}\.\d{3},[+-]\d{3}\.\d{3},[+-]\d{3}\.\d{3},[+-]\d{3}\.\d{3}\r\n)");
const std::regex kAbbRegex(R"(-?\d+,\d+(,-?\d+\.\d{3}){6})");

RobotReply okReply(std::uint32_t cycle, const Pose& p) {
  RobotReply r;
  r.cycleId = cycle;
  r.pose = p;
  return r;
}

Pose poseZyx(double x, double y, double z, double rzDeg, double ryDeg, double rxDeg) {
  const Eigen::Quaterniond q(Eigen::AngleAxisd(deg(rzDeg), Eigen::Vector3d::UnitZ()) *
                             Eigen::AngleAxisd(deg(ryDeg), Eigen::Vector3d::UnitY()) *
                             Eigen::AngleAxisd(deg(rxDeg), Eigen::Vector3d::UnitX()));
  return Pose{x, y, z, q.w(), q.x(), q.y(), q.z()};
}

std::string bytes(std::initializer_list<int> v) {
  std::string s;
  for (int b : v) s.push_back(static_cast<char>(b));
  return s;
}

// ---- fanuc -------------------------------------------------------------------------------

TEST(robot_fanuc, GoldenOk) {
  const RobotReply r = okReply(4711, poseFromXyzRz(512.3, -120.05, 35.0, deg(-12.5)));
  EXPECT_EQ(formatReply(Dialect::Fanuc, r),
            "+0000,0004711,+00512.300,-00120.050,+00035.000,+000.000,+000.000,-012.500\r\n");
}

TEST(robot_fanuc, GoldenWprOrderAndErrors) {
  // W = rx, P = ry, R = rz (R = Rz(R)·Ry(P)·Rx(W)).
  const RobotReply r = okReply(8388607, poseZyx(-99999.999, 99999.999, -0.0004, 30.0, 20.0, 10.0));
  EXPECT_EQ(formatReply(Dialect::Fanuc, r),
            "+0000,8388607,-99999.999,+99999.999,+00000.000,+010.000,+020.000,+030.000\r\n");
  RobotReply e = r;
  e.status = Status::Internal;
  e.cycleId = 12;
  EXPECT_EQ(formatReply(Dialect::Fanuc, e),
            "-0008,0000012,+00000.000,+00000.000,+00000.000,+000.000,+000.000,+000.000\r\n");
  e.status = Status::NoPartFound;
  EXPECT_EQ(formatReply(Dialect::Fanuc, e).substr(0, 14), "+0001,0000012,");
  // Out of range -> INTERNAL with zeros, never a wider column.
  const RobotReply far = okReply(3, Pose{100000.0, 0, 0, 1, 0, 0, 0});
  EXPECT_EQ(formatReply(Dialect::Fanuc, far),
            "-0008,0000003,+00000.000,+00000.000,+00000.000,+000.000,+000.000,+000.000\r\n");
}

// Every reply, any status and pose in range: exactly 75 bytes, every field in its columns.
TEST(robot_fanuc, FixedColumnsOverTheWholeRange) {
  std::mt19937 rng(7);
  std::uniform_real_distribution<double> pos(-99999.999, 99999.999);
  std::uniform_real_distribution<double> comp(-1.0, 1.0);
  const std::vector<Status> statuses = {Status::Ok, Status::NoPartFound, Status::ResultNotReady,
                                        Status::UnknownCommand, Status::Internal, Status::OffsetOutOfLimits};
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(comp(rng), comp(rng), comp(rng), comp(rng)).normalized();
    RobotReply r = okReply(static_cast<std::uint32_t>(i * 419), Pose{pos(rng), pos(rng), pos(rng), q.w(), q.x(), q.y(), q.z()});
    r.status = statuses[static_cast<std::size_t>(i) % statuses.size()];
    const std::string s = formatReply(Dialect::Fanuc, r);
    ASSERT_EQ(s.size(), kFanucReplyChars) << s;
    ASSERT_LT(s.size(), kFanucMaxReplyChars);
    ASSERT_TRUE(std::regex_match(s, kFanucRegex)) << s;
    for (std::size_t comma : {5u, 13u, 24u, 35u, 46u, 55u, 64u}) ASSERT_EQ(s[comma], ',') << s;
    ASSERT_EQ(s.find("-000.000"), std::string::npos) << s;
    ASSERT_EQ(s.find("-00000.000"), std::string::npos) << s;
  }
  // The widest angles: -180 and values rounding up to it.
  for (double a : {-179.9996, 179.9996, -180.0, 180.0}) {
    const std::string s = formatReply(Dialect::Fanuc, okReply(1, poseZyx(0, 0, 0, a, 0, 0)));
    ASSERT_TRUE(std::regex_match(s, kFanucRegex)) << s;
  }
}

// ---- abb: 80 characters for every pose in the cell's range ------------------------------

TEST(robot_abb, NeverLongerThan80ForAnyPoseInRange) {
  std::mt19937 rng(11);
  std::uniform_real_distribution<double> pos(-99999.999, 99999.999);
  std::uniform_real_distribution<double> comp(-1.0, 1.0);
  std::size_t longest = 0;
  for (int i = 0; i < 20000; ++i) {
    const Eigen::Quaterniond q = Eigen::Quaterniond(comp(rng), comp(rng), comp(rng), comp(rng)).normalized();
    RobotReply r = okReply(8388607, Pose{-std::abs(pos(rng)), -std::abs(pos(rng)), -std::abs(pos(rng)), q.w(), q.x(), q.y(), q.z()});
    if (i % 3 == 0) r.status = Status::OffsetOutOfLimits;
    const std::string s = formatReply(Dialect::Abb, r);
    ASSERT_LE(s.size(), kAbbMaxReplyChars) << s;
    ASSERT_TRUE(std::regex_match(s, kAbbRegex)) << s;
    longest = std::max(longest, s.size());
  }
  // The longest possible Ok reply is 68 characters ("0,8388607," + 3 x "-99999.999," +
  // "-180.000,-90.000,-180.000"): the sweep must come close to it.
  EXPECT_GE(longest, 66u);
}

// ---- binary ------------------------------------------------------------------------------

TEST(robot_binary, GoldenReplyFrame) {
  const RobotReply r = okReply(4711, poseFromXyzRz(512.3, -120.05, 35.0, deg(-12.5)));
  const std::string expected =
      bytes({0x56, 0x47, 0x52, 0x41, 0x00, 0x00, 0x00, 0x28, 0x00, 0x00, 0x00, 0x00, 0x00, 0x00, 0x12, 0x67,
             0x00, 0x07, 0xd1, 0x2c, 0xff, 0xfe, 0x2b, 0x0e, 0x00, 0x00, 0x88, 0xb8, 0x00, 0x00, 0x00, 0x00,
             0x00, 0x00, 0x00, 0x00, 0xff, 0xff, 0xcf, 0x2c});
  EXPECT_EQ(formatReply(Dialect::Binary, r), expected);
  RobotReply e;
  e.status = Status::JobNotFound;
  e.cycleId = 5;
  const std::string err = formatReply(Dialect::Binary, e);
  ASSERT_EQ(err.size(), binary::kReplyBytes);
  EXPECT_EQ(binary::readInt32(err, 0), static_cast<std::int32_t>(binary::kReplyMagic));
  EXPECT_EQ(binary::readInt32(err, 8), -7);
  EXPECT_EQ(binary::readInt32(err, 12), 5);
  for (std::size_t at = 16; at < 40; at += 4) EXPECT_EQ(binary::readInt32(err, at), 0);
}

TEST(robot_binary, ScalesAndRoundsToMicrometresAndMillidegrees) {
  const RobotReply r = okReply(1, poseZyx(-99999.999, 0.0004, 0.0006, 30.0, 20.0, 10.0));
  const std::string f = formatReply(Dialect::Binary, r);
  EXPECT_EQ(binary::readInt32(f, 16), -99999999);
  EXPECT_EQ(binary::readInt32(f, 20), 0);
  EXPECT_EQ(binary::readInt32(f, 24), 1);
  EXPECT_EQ(binary::readInt32(f, 28), 10000);  // W = rx
  EXPECT_EQ(binary::readInt32(f, 32), 20000);  // P = ry
  EXPECT_EQ(binary::readInt32(f, 36), 30000);  // R = rz
}

TEST(robot_binary, RequestFramesDecode) {
  EXPECT_EQ(binary::encodeRequest(binary::kCmdGet, 7), bytes({0x56, 0x47, 0x52, 0x51, 0, 0, 0, 0x10, 0, 0, 0, 1, 0, 0, 0, 7}));
  RequestDecoder d(Dialect::Binary);
  d.append(binary::encodeRequest(binary::kCmdGet, 7) + binary::encodeRequest(binary::kCmdGetLast, 3) +
           binary::encodeRequest(binary::kCmdJob, 2) + binary::encodeRequest(binary::kCmdGet, 0));
  auto a = d.next();
  ASSERT_TRUE(a && *a);
  EXPECT_EQ((*a)->job, 7);
  EXPECT_FALSE((*a)->last);
  auto b = d.next();
  ASSERT_TRUE(b && *b);
  EXPECT_EQ((*b)->job, 3);
  EXPECT_TRUE((*b)->last);
  auto c = d.next();
  ASSERT_TRUE(c && *c);
  EXPECT_EQ((*c)->command, Command::Job);
  EXPECT_EQ((*c)->job, 2);
  auto g = d.next();
  ASSERT_TRUE(g && *g);
  EXPECT_EQ((*g)->job, 0);
  EXPECT_FALSE(d.next());
}

TEST(robot_binary, ByteAtATimeAndGarbageResync) {
  RequestDecoder d(Dialect::Binary);
  const std::string stream = std::string("garbage!VG") + binary::encodeRequest(binary::kCmdGet, 9) +
                             binary::encodeRequest(99, 1) + binary::encodeRequest(binary::kCmdGet, 40000) +
                             binary::encodeRequest(binary::kCmdJob, 0) + binary::encodeRequest(binary::kCmdGet, 1);
  std::vector<int> got;  // job, or -status for errors
  for (char ch : stream) {
    d.append(std::string_view(&ch, 1));
    while (auto r = d.next()) got.push_back(*r ? (*r)->job : -100 - statusCode(r->error().code));
  }
  // garbage -> one -1; GET 9; unknown command -> -1; job 40000 -> -2; JOB 0 -> -2; GET 1.
  EXPECT_EQ(got, (std::vector<int>{-99, 9, -99, -98, -98, 1}));
}

TEST(robot_binary, WrongLengthSkipsToTheNextMagic) {
  RequestDecoder d(Dialect::Binary);
  std::string bad = binary::encodeRequest(binary::kCmdGet, 1);
  bad[7] = 20;  // length 20
  d.append(bad + binary::encodeRequest(binary::kCmdGet, 2));
  auto e = d.next();
  ASSERT_TRUE(e && !*e);
  EXPECT_EQ(e->error().code, Status::BadArgument);
  std::vector<int> jobs;
  while (auto r = d.next()) jobs.push_back(*r ? (*r)->job : -1);
  EXPECT_EQ(jobs, (std::vector<int>{2}));  // one error for the bad frame, then job 2
}

// ---- strict pose frame -------------------------------------------------------------------

TEST(robot_strict_frame, GoldenAndErrors) {
  auto f = formatStrictPoseFrame(poseFromXyzRz(512.3, -120.05, 35.0, deg(-12.5)));
  ASSERT_TRUE(f);
  EXPECT_EQ(*f, "(0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)");
  EXPECT_FALSE(formatStrictPoseFrame(Pose{std::numeric_limits<double>::quiet_NaN(), 0, 0, 1, 0, 0, 0}));
  EXPECT_FALSE(formatStrictPoseFrame(Pose{0, 100000.0, 0, 1, 0, 0, 0}));
}

}  // namespace
}  // namespace vgr::protocol
