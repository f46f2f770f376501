// Golden bytes and conformance for the robot codec (protocol/robot_codec.hpp): the `ur`
// and `abb` dialects of PROTOCOLS.md. Suites are named robot_* so `ctest -R robot` finds them.
// GCC 12 reports a false -Wmaybe-uninitialized inside <regex>'s std::function members when
// built with -fsanitize (VGR_SANITIZE); it must not break -Werror there. Test code only.
#if defined(__GNUC__) && !defined(__clang__)
#pragma GCC diagnostic ignored "-Wmaybe-uninitialized"
#endif
#include "protocol/robot_codec.hpp"

#include <gtest/gtest.h>

#include <cmath>
#include <cstdint>
#include <limits>
#include <locale>
#include <random>
#include <regex>
#include <string>
#include <vector>

#include <Eigen/Geometry>

namespace vgr::protocol {
namespace {

const std::regex kUrRegex(R"(\(-?\d+,\d+(,-?\d+\.\d{6}){6}\))");
const std::regex kAbbRegex(R"(-?\d+,\d+(,-?\d+\.\d{3}){6})");

constexpr double kPi = 3.14159265358979323846;
double deg(double d) { return d * kPi / 180.0; }

Pose poseFromEigen(double x, double y, double z, const Eigen::Quaterniond& q) {
  const Eigen::Quaterniond n = q.normalized();
  return Pose{x, y, z, n.w(), n.x(), n.y(), n.z()};
}

// R = Rz(rz) * Ry(ry) * Rx(rx), angles in degrees.
Eigen::Matrix3d zyx(double rzDeg, double ryDeg, double rxDeg) {
  return (Eigen::AngleAxisd(deg(rzDeg), Eigen::Vector3d::UnitZ()) *
          Eigen::AngleAxisd(deg(ryDeg), Eigen::Vector3d::UnitY()) *
          Eigen::AngleAxisd(deg(rxDeg), Eigen::Vector3d::UnitX()))
      .toRotationMatrix();
}

Pose poseZyx(double x, double y, double z, double rzDeg, double ryDeg, double rxDeg) {
  return poseFromEigen(x, y, z, Eigen::Quaterniond(zyx(rzDeg, ryDeg, rxDeg)));
}

RobotReply okReply(std::uint32_t cycle, const Pose& p) {
  RobotReply r;
  r.status = Status::Ok;
  r.cycleId = cycle;
  r.pose = p;
  return r;
}

// Splits "a,b,c" (optionally wrapped in parentheses) into doubles.
std::vector<double> numbers(std::string s) {
  if (!s.empty() && s.front() == '(') s = s.substr(1, s.size() - 2);
  std::vector<double> out;
  std::size_t pos = 0;
  while (pos <= s.size()) {
    const std::size_t comma = s.find(',', pos);
    out.push_back(std::stod(s.substr(pos, comma - pos)));
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return out;
}

// ---------------------------------------------------------------------------------------
// Dialect names

TEST(robot_codec, ParseDialect) {
  EXPECT_EQ(parseDialect("ur"), Dialect::Ur);
  EXPECT_EQ(parseDialect("abb"), Dialect::Abb);
  EXPECT_EQ(parseDialect("UR"), std::nullopt);
  EXPECT_EQ(parseDialect("fanuc"), Dialect::Fanuc);
  EXPECT_EQ(parseDialect("binary"), Dialect::Binary);
  EXPECT_EQ(parseDialect("strict"), Dialect::Strict);
  EXPECT_EQ(parseDialect("kuka"), std::nullopt);
  EXPECT_EQ(parseDialect(""), std::nullopt);
  for (Dialect d : {Dialect::Ur, Dialect::Abb, Dialect::Fanuc, Dialect::Binary, Dialect::Strict})
    EXPECT_EQ(parseDialect(dialectName(d)), d);
  EXPECT_EQ(dialectName(Dialect::Ur), "ur");
  EXPECT_EQ(dialectName(Dialect::Abb), "abb");
}

// ---------------------------------------------------------------------------------------
// Golden bytes

TEST(robot_codec, GoldenUr) {
  const RobotReply r = okReply(4711, poseFromXyzRz(512.3, -120.05, 35.0, deg(-12.5)));
  EXPECT_EQ(formatReply(Dialect::Ur, r), "(0,4711,0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)");
}

TEST(robot_codec, GoldenAbb) {
  const RobotReply r = okReply(4711, poseFromXyzRz(512.3, -120.05, 35.0, deg(-12.5)));
  EXPECT_EQ(formatReply(Dialect::Abb, r), "0,4711,512.300,-120.050,35.000,-12.500,0.000,0.000");
}

TEST(robot_codec, GoldenErrorRepliesCarryZeros) {
  RobotReply r = okReply(12, poseFromXyzRz(512.3, -120.05, 35.0, deg(-12.5)));
  r.status = Status::NoPartFound;
  EXPECT_EQ(formatReply(Dialect::Ur, r), "(1,12,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000)");
  EXPECT_EQ(formatReply(Dialect::Abb, r), "1,12,0.000,0.000,0.000,0.000,0.000,0.000");
  r.status = Status::UnknownCommand;
  r.cycleId = 0;
  EXPECT_EQ(formatReply(Dialect::Ur, r), "(-1,0,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000)");
  EXPECT_EQ(formatReply(Dialect::Abb, r), "-1,0,0.000,0.000,0.000,0.000,0.000,0.000");
  r.status = Status::BadArgument;
  EXPECT_EQ(formatReply(Dialect::Abb, r), "-2,0,0.000,0.000,0.000,0.000,0.000,0.000");
}

TEST(robot_codec, GoldenMultiAxisPose) {
  // rz=30, ry=20, rx=10 degrees: ABB prints the Euler angles back unchanged.
  const RobotReply r = okReply(7, poseZyx(-250.0, 1000.5, -5.25, 30.0, 20.0, 10.0));
  EXPECT_EQ(formatReply(Dialect::Abb, r), "0,7,-250.000,1000.500,-5.250,30.000,20.000,10.000");
  // Rotation vector of Rz(30)Ry(20)Rx(10), computed independently (Rodrigues, in Python).
  EXPECT_EQ(formatReply(Dialect::Ur, r), "(0,7,-0.250000,1.000500,-0.005250,0.077525,0.384852,0.486479)");
}

TEST(robot_codec, NeverPrintsNegativeZero) {
  // -0.0004 mm rounds to 0.000 (ABB); -0.0000004 m rounds to 0.000000 (UR).
  const RobotReply r = okReply(1, Pose{-0.0004, -0.0, -0.0000001, 1, 0, 0, 0});
  EXPECT_EQ(formatReply(Dialect::Abb, r), "0,1,0.000,0.000,0.000,0.000,0.000,0.000");
  EXPECT_EQ(formatReply(Dialect::Ur, r), "(0,1,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000)");
  // A tiny negative rotation as well.
  const RobotReply r2 = okReply(1, poseFromXyzRz(0, 0, 0, deg(-0.0001)));
  EXPECT_EQ(formatReply(Dialect::Abb, r2), "0,1,0.000,0.000,0.000,0.000,0.000,0.000");
  // But a real negative value keeps its sign.
  const RobotReply r3 = okReply(1, Pose{-0.0006, 0, 0, 1, 0, 0, 0});
  EXPECT_EQ(formatReply(Dialect::Abb, r3), "0,1,-0.001,0.000,0.000,0.000,0.000,0.000");
}

TEST(robot_codec, IgnoresGlobalLocale) {
  struct CommaDecimal : std::numpunct<char> {
    char do_decimal_point() const override { return ','; }
    char do_thousands_sep() const override { return '.'; }
    std::string do_grouping() const override { return "\3"; }
  };
  const std::locale previous = std::locale::global(std::locale(std::locale::classic(), new CommaDecimal));
  const RobotReply r = okReply(4711, poseFromXyzRz(1512.3, -120.05, 35.0, deg(-12.5)));
  const std::string abb = formatReply(Dialect::Abb, r);
  const std::string ur = formatReply(Dialect::Ur, r);
  std::locale::global(previous);
  EXPECT_EQ(abb, "0,4711,1512.300,-120.050,35.000,-12.500,0.000,0.000");
  EXPECT_EQ(ur, "(0,4711,1.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)");
}

// ---------------------------------------------------------------------------------------
// Bounds: 80 characters for RAPID, never NaN

TEST(robot_codec, NonFiniteBecomesInternalWithZeros) {
  const double nan = std::numeric_limits<double>::quiet_NaN();
  const double inf = std::numeric_limits<double>::infinity();
  const std::vector<Pose> bad = {
      Pose{nan, 0, 0, 1, 0, 0, 0}, Pose{0, inf, 0, 1, 0, 0, 0}, Pose{0, 0, -inf, 1, 0, 0, 0},
      Pose{0, 0, 0, nan, 0, 0, 0}, Pose{0, 0, 0, 1, 0, 0, inf}, Pose{0, 0, 0, 0, 0, 0, 0},  // zero quaternion
  };
  for (const Pose& p : bad) {
    const RobotReply r = okReply(99, p);
    EXPECT_EQ(formatReply(Dialect::Abb, r), "-8,99,0.000,0.000,0.000,0.000,0.000,0.000");
    EXPECT_EQ(formatReply(Dialect::Ur, r), "(-8,99,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000)");
  }
}

TEST(robot_codec, OutOfRangePositionBecomesInternal) {
  for (double v : {100000.0, -100000.0, 99999.9995, 1e300}) {
    for (int axis = 0; axis < 3; ++axis) {
      Pose p;
      (axis == 0 ? p.x : axis == 1 ? p.y : p.z) = v;
      const RobotReply r = okReply(5, p);
      EXPECT_EQ(formatReply(Dialect::Abb, r), "-8,5,0.000,0.000,0.000,0.000,0.000,0.000") << v;
      EXPECT_EQ(formatReply(Dialect::Ur, r).substr(0, 6), "(-8,5,") << v;
    }
  }
  // The limit itself is fine.
  const RobotReply ok = okReply(5, Pose{99999.999, -99999.999, 99999.999, 1, 0, 0, 0});
  EXPECT_EQ(formatReply(Dialect::Abb, ok), "0,5,99999.999,-99999.999,99999.999,0.000,0.000,0.000");
  EXPECT_EQ(formatReply(Dialect::Ur, ok), "(0,5,99.999999,-99.999999,99.999999,0.000000,0.000000,0.000000)");
}

TEST(robot_codec, AbbNeverLongerThan80OverExtremes) {
  const std::vector<Status> statuses = {Status::Ok, Status::NoPartFound, Status::UnknownCommand, Status::Internal,
                                        Status::OffsetOutOfLimits};
  const std::vector<double> positions = {-99999.999, -0.0004, 0.0, 99999.999};
  // Euler angles that print with the most characters: -180.000, -89.999..., -179.9996.
  const std::vector<Eigen::Vector3d> angles = {{-179.9996, -89.9, -179.9996},
                                               {180.0, 0.0, 180.0},
                                               {-179.9, 89.9, 179.9},
                                               {0.0, -90.0, 0.0},
                                               {-123.456, -45.678, -98.765}};
  std::size_t longest = 0;
  for (Status s : statuses) {
    for (std::uint32_t cycle : {0u, 8388607u, std::numeric_limits<std::uint32_t>::max()}) {
      for (double x : positions) {
        for (double y : positions) {
          for (const auto& a : angles) {
            RobotReply r = okReply(cycle, poseZyx(x, y, -99999.999, a.x(), a.y(), a.z()));
            r.status = s;
            const std::string abb = formatReply(Dialect::Abb, r);
            const std::string ur = formatReply(Dialect::Ur, r);
            ASSERT_LE(abb.size(), kAbbMaxReplyChars) << abb;
            ASSERT_TRUE(std::regex_match(abb, kAbbRegex)) << abb;
            ASSERT_TRUE(std::regex_match(ur, kUrRegex)) << ur;
            longest = std::max(longest, abb.size());
          }
        }
      }
    }
  }
  EXPECT_GE(longest, 70u);  // the sweep really hit the long cases
}

TEST(robot_codec, RandomPosesMatchDialectRegex) {
  std::mt19937 rng(12345);
  std::uniform_real_distribution<double> pos(-99999.999, 99999.999);
  std::uniform_real_distribution<double> comp(-1.0, 1.0);
  std::uniform_int_distribution<std::uint32_t> cyc(0, 8388607);
  for (int i = 0; i < 5000; ++i) {
    const Eigen::Quaterniond q(comp(rng), comp(rng), comp(rng), comp(rng));
    const RobotReply r = okReply(cyc(rng), poseFromEigen(pos(rng), pos(rng), pos(rng) / 1000.0, q));
    const std::string abb = formatReply(Dialect::Abb, r);
    const std::string ur = formatReply(Dialect::Ur, r);
    ASSERT_TRUE(std::regex_match(abb, kAbbRegex)) << abb;
    ASSERT_LE(abb.size(), kAbbMaxReplyChars) << abb;
    ASSERT_TRUE(std::regex_match(ur, kUrRegex)) << ur;
    ASSERT_EQ(abb.find("-0.000,"), std::string::npos) << abb;
    ASSERT_EQ(ur.find("-0.000000"), std::string::npos) << ur;
  }
}

// ---------------------------------------------------------------------------------------
// Rotation conventions: UR rotation vector and ABB Z-Y-X angles describe the same rotation

TEST(robot_codec, RotationGolden180AboutZ) {
  const RobotReply r = okReply(1, poseFromXyzRz(0, 0, 0, deg(180.0)));
  const std::string ur = formatReply(Dialect::Ur, r);
  const std::string abb = formatReply(Dialect::Abb, r);
  // The rotation vector of a half turn is +-pi * axis; either sign is the same rotation.
  EXPECT_TRUE(ur == "(0,1,0.000000,0.000000,0.000000,0.000000,0.000000,3.141593)" ||
              ur == "(0,1,0.000000,0.000000,0.000000,0.000000,0.000000,-3.141593)")
      << ur;
  EXPECT_TRUE(abb == "0,1,0.000,0.000,0.000,180.000,0.000,0.000" || abb == "0,1,0.000,0.000,0.000,-180.000,0.000,0.000")
      << abb;
}

TEST(robot_codec, RotationGoldenQuarterTurns) {
  EXPECT_EQ(formatReply(Dialect::Ur, okReply(1, poseFromXyzRz(0, 0, 0, deg(90.0)))),
            "(0,1,0.000000,0.000000,0.000000,0.000000,0.000000,1.570796)");
  EXPECT_EQ(formatReply(Dialect::Abb, okReply(1, poseFromXyzRz(0, 0, 0, deg(90.0)))),
            "0,1,0.000,0.000,0.000,90.000,0.000,0.000");
  EXPECT_EQ(formatReply(Dialect::Ur, okReply(1, poseFromXyzRz(0, 0, 0, deg(-90.0)))),
            "(0,1,0.000000,0.000000,0.000000,0.000000,0.000000,-1.570796)");
  EXPECT_EQ(formatReply(Dialect::Abb, okReply(1, poseFromXyzRz(0, 0, 0, deg(-90.0)))),
            "0,1,0.000,0.000,0.000,-90.000,0.000,0.000");
  // Tool pointing down (half turn about x), the usual pick orientation.
  const Pose down = poseZyx(0, 0, 0, 0.0, 0.0, 180.0);
  const std::string urDown = formatReply(Dialect::Ur, okReply(1, down));
  EXPECT_TRUE(urDown == "(0,1,0.000000,0.000000,0.000000,3.141593,0.000000,0.000000)" ||
              urDown == "(0,1,0.000000,0.000000,0.000000,-3.141593,0.000000,0.000000)")
      << urDown;
}

TEST(robot_codec, RotationVectorAndEulerAgree) {
  struct Case {
    double rz, ry, rx;
  };
  const std::vector<Case> cases = {{0, 0, 0},     {-12.5, 0, 0},  {180, 0, 0},     {-180, 0, 0},
                                   {90, 0, 0},    {30, 20, 10},   {-12.5, 0, 180}, {170, -60, -170},
                                   {45, 89.5, 0}, {0, -89.5, 45}, {179.9, 0, 0},   {-179.9, 10, 179}};
  for (const Case& c : cases) {
    const Eigen::Matrix3d expected = zyx(c.rz, c.ry, c.rx);
    const RobotReply r = okReply(3, poseFromEigen(100, 200, 300, Eigen::Quaterniond(expected)));

    const std::vector<double> ur = numbers(formatReply(Dialect::Ur, r));
    ASSERT_EQ(ur.size(), 8u);
    EXPECT_NEAR(ur[2], 0.1, 1e-9);
    EXPECT_NEAR(ur[3], 0.2, 1e-9);
    EXPECT_NEAR(ur[4], 0.3, 1e-9);
    const Eigen::Vector3d rv(ur[5], ur[6], ur[7]);
    ASSERT_LE(rv.norm(), kPi + 1e-5);  // URScript expects the angle in [0, pi]
    const Eigen::Matrix3d fromUr = rv.norm() < 1e-12 ? Eigen::Matrix3d::Identity()
                                                     : Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
    EXPECT_LT((fromUr - expected).cwiseAbs().maxCoeff(), 1e-5) << c.rz << " " << c.ry << " " << c.rx;

    const std::vector<double> abb = numbers(formatReply(Dialect::Abb, r));
    ASSERT_EQ(abb.size(), 8u);
    EXPECT_DOUBLE_EQ(abb[2], 100.0);
    const Eigen::Matrix3d fromAbb = zyx(abb[5], abb[6], abb[7]);
    EXPECT_LT((fromAbb - expected).cwiseAbs().maxCoeff(), 5e-5) << c.rz << " " << c.ry << " " << c.rx;
    EXPECT_LE(std::abs(abb[5]), 180.0);
    EXPECT_LE(std::abs(abb[6]), 90.0);
    EXPECT_LE(std::abs(abb[7]), 180.0);
  }
}

// ---------------------------------------------------------------------------------------
// Request parsing

TEST(robot_codec, ParseGoodRequests) {
  auto r = parseRequest("GET,1");
  ASSERT_TRUE(r) << r.error().message;
  EXPECT_EQ(r->job, 1);
  EXPECT_FALSE(r->last);

  r = parseRequest("GET,32767,LAST");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->job, 32767);
  EXPECT_TRUE(r->last);

  r = parseRequest("  GET , 12 ,\tLAST  ");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->job, 12);
  EXPECT_TRUE(r->last);

  r = parseRequest("GET,007");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->job, 7);

  r = parseRequest("GET");  // the robot's current job
  ASSERT_TRUE(r);
  EXPECT_EQ(r->command, Command::Get);
  EXPECT_EQ(r->job, 0);
  EXPECT_FALSE(r->last);

  r = parseRequest("JOB,12");
  ASSERT_TRUE(r);
  EXPECT_EQ(r->command, Command::Job);
  EXPECT_EQ(r->job, 12);
}

TEST(robot_codec, ParseBadRequests) {
  const std::vector<std::string> unknown = {
      "", "HELLO", "get,1", "Get,1", "job,1", "GETX,1", "GET 1", "PUT,1", std::string("\x00\x01\xff", 3), "(GET,1)"};
  for (const std::string& s : unknown) {
    const auto r = parseRequest(s);
    ASSERT_FALSE(r) << s;
    EXPECT_EQ(r.error().code, Status::UnknownCommand) << s;
    EXPECT_EQ(statusCode(r.error().code), -1);
  }
  const std::vector<std::string> badArg = {"JOB",     "JOB,0",      "JOB,1,LAST", "JOB,x",
                                           "GET,",       "GET, ",     "GET,abc",         "GET,0",
                                           "GET,-1",  "GET,+1",     "GET,32768", "GET,99999999999", "GET,1.5",
                                           "GET,1 2", "GET,1,last", "GET,1,",    "GET,1,LAST,2",    "GET,,LAST",
                                           "GET,1x"};
  for (const std::string& s : badArg) {
    const auto r = parseRequest(s);
    ASSERT_FALSE(r) << s;
    EXPECT_EQ(r.error().code, Status::BadArgument) << s;
    EXPECT_EQ(statusCode(r.error().code), -2);
  }
}

// ---------------------------------------------------------------------------------------
// Request splitting

// Collects every request currently available; errors appear as "<ERR>".
std::vector<std::string> drain(RequestSplitter& s) {
  std::vector<std::string> out;
  while (auto r = s.next()) out.push_back(*r ? **r : std::string("<ERR>"));
  return out;
}

using Lines = std::vector<std::string>;

TEST(robot_splitter, EachTerminator) {
  for (const char* input : {"GET,1#", "GET,1\r", "GET,1\n", "GET,1\r\n"}) {
    RequestSplitter s;
    s.append(input);
    EXPECT_EQ(drain(s), Lines{"GET,1"}) << input;
    EXPECT_EQ(s.buffered(), 0u);
  }
}

TEST(robot_splitter, MergedAndEmptyRequests) {
  RequestSplitter s;
  s.append("GET,1#GET,2#");
  EXPECT_EQ(drain(s), (Lines{"GET,1", "GET,2"}));
  s.append("GET,3\r\nGET,4\r\n\r\n##\n \t\nGET,5,LAST\n");
  EXPECT_EQ(drain(s), (Lines{"GET,3", "GET,4", "GET,5,LAST"}));
}

TEST(robot_splitter, ByteAtATime) {
  RequestSplitter s;
  const std::string input = "GET,1\r\nGET,2#HELLO\n";
  Lines got;
  for (char c : input) {
    s.append(std::string_view(&c, 1));
    for (auto& l : drain(s)) got.push_back(l);
  }
  EXPECT_EQ(got, (Lines{"GET,1", "GET,2", "HELLO"}));
}

TEST(robot_splitter, PartialRequestWaits) {
  RequestSplitter s;
  s.append("GET,");
  EXPECT_TRUE(drain(s).empty());
  EXPECT_EQ(s.buffered(), 4u);
  s.append("12");
  EXPECT_TRUE(drain(s).empty());
  s.append("#GE");
  EXPECT_EQ(drain(s), Lines{"GET,12"});
  EXPECT_EQ(s.buffered(), 2u);
}

TEST(robot_splitter, MaxLengthIsAcceptedOneMoreIsNot) {
  RequestSplitter s(16);
  s.append(std::string(16, 'A') + "\n");
  EXPECT_EQ(drain(s), Lines{std::string(16, 'A')});
  s.append(std::string(17, 'B') + "\nGET,1\n");
  EXPECT_EQ(drain(s), (Lines{"<ERR>", "GET,1"}));
}

TEST(robot_splitter, TooLongYieldsOneErrorThenResyncs) {
  RequestSplitter s(256);
  // 10 kB in 512-byte reads, no terminator until the end, then a good request.
  const std::string big(10 * 1024, 'X');
  Lines got;
  for (std::size_t i = 0; i < big.size(); i += 512) {
    s.append(std::string_view(big).substr(i, 512));
    for (auto& l : drain(s)) got.push_back(l);
    EXPECT_LE(s.buffered(), 256u + 512u);  // bounded memory while discarding
  }
  EXPECT_EQ(got, Lines{"<ERR>"});
  EXPECT_TRUE(s.discarding());
  s.append("XXXX\r\nGET,1\n");
  EXPECT_EQ(drain(s), Lines{"GET,1"});
  EXPECT_FALSE(s.discarding());
}

TEST(robot_splitter, TooLongErrorStatusIsUnknownCommand) {
  RequestSplitter s(8);
  s.append("123456789");
  auto r = s.next();
  ASSERT_TRUE(r.has_value());
  ASSERT_FALSE(r->has_value());
  EXPECT_EQ(r->error().code, Status::UnknownCommand);
  EXPECT_FALSE(s.next().has_value());
}

TEST(robot_splitter, BinaryBytesAreARequest) {
  RequestSplitter s;
  s.append(std::string("\x00\x01\xfe\xff\n", 5));
  const Lines got = drain(s);
  ASSERT_EQ(got.size(), 1u);
  EXPECT_EQ(got[0], std::string("\x00\x01\xfe\xff", 4));
  EXPECT_EQ(parseRequest(got[0]).error().code, Status::UnknownCommand);
}

}  // namespace
}  // namespace vgr::protocol

// ---------------------------------------------------------------------------------------
// reply_label: the part's label and confidence after the pose (robot_codec.hpp, withLabel)

namespace vgr::protocol {
namespace {

RobotReply labelledReply(std::uint32_t cycle, const Pose& p, int label, double confidence) {
  RobotReply r = okReply(cycle, p);
  r.label = label;
  r.confidence = confidence;
  return r;
}

TEST(robot_label, GoldenEveryDialect) {
  const RobotReply r = labelledReply(4711, poseFromXyzRz(512.3, -120.05, 35.0, deg(-12.5)), 3, 0.9536);
  EXPECT_EQ(formatReply(Dialect::Ur, r, true), "(0,4711,0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166,3,0.954)");
  EXPECT_EQ(formatReply(Dialect::Abb, r, true), "0,4711,512.300,-120.050,35.000,-12.500,0.000,0.000,3,0.954");
  EXPECT_EQ(formatReply(Dialect::Fanuc, r, true),
            "+0000,0004711,+00512.300,-00120.050,+00035.000,+000.000,+000.000,-012.500,003,0.954\r\n");
  EXPECT_EQ(formatReply(Dialect::Fanuc, r, true).size(), kFanucLabelReplyChars);
  const std::string bin = formatReply(Dialect::Binary, r, true);
  ASSERT_EQ(bin.size(), binary::kLabelReplyBytes);
  EXPECT_EQ(binary::readInt32(bin, 4), 48);
  EXPECT_EQ(binary::readInt32(bin, 8), 0);
  EXPECT_EQ(binary::readInt32(bin, 12), 4711);
  EXPECT_EQ(binary::readInt32(bin, 16), 512300);
  EXPECT_EQ(binary::readInt32(bin, 40), 3);
  EXPECT_EQ(binary::readInt32(bin, 44), 954);
  // Without reply_label every dialect is byte for byte what it was.
  EXPECT_EQ(formatReply(Dialect::Ur, r), "(0,4711,0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)");
  EXPECT_EQ(formatReply(Dialect::Abb, r), "0,4711,512.300,-120.050,35.000,-12.500,0.000,0.000");
  EXPECT_EQ(formatReply(Dialect::Binary, r).size(), binary::kReplyBytes);
  EXPECT_EQ(formatReply(Dialect::Fanuc, r).size(), kFanucReplyChars);
  // Strict has no room: its frame stays paper 002's.
  EXPECT_EQ(formatReply(Dialect::Strict, r, true), formatReply(Dialect::Strict, r));
}

TEST(robot_label, ErrorRepliesCarryZeroLabel) {
  RobotReply r = labelledReply(12, poseFromXyzRz(1, 2, 3, 0), 4, 0.99);
  r.status = Status::NoPartFound;
  EXPECT_EQ(formatReply(Dialect::Ur, r, true), "(1,12,0.000000,0.000000,0.000000,0.000000,0.000000,0.000000,0,0.000)");
  EXPECT_EQ(formatReply(Dialect::Abb, r, true), "1,12,0.000,0.000,0.000,0.000,0.000,0.000,0,0.000");
}

TEST(robot_label, LabelTheWireCannotCarryIsAnError) {
  for (const auto& [label, conf] : std::vector<std::pair<int, double>>{{1000, 0.9}, {-1, 0.9}, {2, 1.5}, {2, std::nan("")}}) {
    const RobotReply r = labelledReply(5, poseFromXyzRz(1, 2, 3, 0), label, conf);
    EXPECT_EQ(formatReply(Dialect::Abb, r, true), "-8,5,0.000,0.000,0.000,0.000,0.000,0.000,0,0.000") << label << " " << conf;
    EXPECT_EQ(formatReply(Dialect::Ur, r, true).substr(0, 6), "(-8,5,") << label;
    EXPECT_EQ(formatReply(Dialect::Fanuc, r, true).substr(0, 6), "-0008,") << label;
  }
  // The largest label and a confidence of 1 fit.
  EXPECT_EQ(formatReply(Dialect::Abb, labelledReply(5, poseFromXyzRz(1, 2, 3, 0), kMaxReplyLabel, 1.0), true),
            "0,5,1.000,2.000,3.000,0.000,0.000,0.000,999,1.000");
}

// RAPID's 80 characters and URScript's 30 values hold for every reply the daemon can send
// (cycle ids below 2^23, any label the wire takes, every status, extreme poses).
TEST(robot_label, AbbStaysWithin80AndUrWithin30Values) {
  const std::regex abbLabel(R"(-?\d+,\d+(,-?\d+\.\d{3}){6},\d{1,3},[01]\.\d{3})");
  const std::regex urLabel(R"(\(-?\d+,\d+(,-?\d+\.\d{6}){6},\d{1,3},[01]\.\d{3}\))");
  const std::vector<Status> statuses = {Status::Ok, Status::NoPartFound, Status::Internal, Status::OffsetOutOfLimits};
  const std::vector<Eigen::Vector3d> angles = {{-179.9996, -89.9, -179.9996}, {180.0, 0.0, 180.0}, {-123.456, -45.678, -98.765}};
  std::size_t longest = 0;
  for (Status s : statuses)
    for (std::uint32_t cycle : {0u, 8388607u})
      for (double x : {-99999.999, 0.0, 99999.999})
        for (const auto& a : angles)
          for (int label : {0, 7, kMaxReplyLabel}) {
            RobotReply r = labelledReply(cycle, poseZyx(x, -99999.999, -99999.999, a.x(), a.y(), a.z()), label, 0.9995);
            r.status = s;
            const std::string abb = formatReply(Dialect::Abb, r, true);
            ASSERT_LE(abb.size(), kAbbMaxReplyChars) << abb;
            ASSERT_TRUE(std::regex_match(abb, abbLabel)) << abb;
            if (s == Status::Ok) {
              EXPECT_EQ(abb.substr(0, 2), "0,") << abb;  // never turned into an error by its length
            }
            const std::string ur = formatReply(Dialect::Ur, r, true);
            ASSERT_TRUE(std::regex_match(ur, urLabel)) << ur;
            EXPECT_EQ(numbers(ur).size(), 10u);
            longest = std::max(longest, abb.size());
          }
  EXPECT_GE(longest, 78u);  // the sweep reached the longest Ok reply
}

}  // namespace
}  // namespace vgr::protocol
