// Rotation conventions per dialect (ARCHITECTURE.md, "Units"), checked against formulas
// written out here by hand, independent of core/pose.cpp and of Eigen's conversions:
//   quaternion (w,x,y,z) -> matrix            (Hamilton, unit quaternion)
//   Z-Y-X Euler (ABB OrientZYX; FANUC W,P,R)   R = Rz(rz)·Ry(ry)·Rx(rx), W = rx, P = ry, R = rz
//   UR rotation vector                         Rodrigues: R = I + sin t K + (1 - cos t) K^2
// Every dialect's text is parsed back and the rotation rebuilt; singular cases included:
// identity, half turns (rotation vector sign), |ry| = 90 degrees (gimbal lock), angles
// near +-180 degrees.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <random>
#include <string>
#include <vector>

#include <fmt/core.h>

#include "protocol/robot_codec.hpp"

namespace vgr::protocol {
namespace {

using Mat = std::array<std::array<double, 3>, 3>;
constexpr double kPi = 3.14159265358979323846;
constexpr double rad(double d) { return d * kPi / 180.0; }

Mat mul(const Mat& a, const Mat& b) {
  Mat c{};
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j)
      for (int k = 0; k < 3; ++k) c[i][j] += a[i][k] * b[k][j];
  return c;
}
Mat rotX(double a) { return {{{1, 0, 0}, {0, std::cos(a), -std::sin(a)}, {0, std::sin(a), std::cos(a)}}}; }
Mat rotY(double a) { return {{{std::cos(a), 0, std::sin(a)}, {0, 1, 0}, {-std::sin(a), 0, std::cos(a)}}}; }
Mat rotZ(double a) { return {{{std::cos(a), -std::sin(a), 0}, {std::sin(a), std::cos(a), 0}, {0, 0, 1}}}; }
Mat zyxDeg(double rz, double ry, double rx) { return mul(mul(rotZ(rad(rz)), rotY(rad(ry))), rotX(rad(rx))); }

Mat fromQuaternion(double w, double x, double y, double z) {
  const double n = std::sqrt(w * w + x * x + y * y + z * z);
  w /= n, x /= n, y /= n, z /= n;
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - w * z), 2 * (x * z + w * y)},
           {2 * (x * y + w * z), 1 - 2 * (x * x + z * z), 2 * (y * z - w * x)},
           {2 * (x * z - w * y), 2 * (y * z + w * x), 1 - 2 * (x * x + y * y)}}};
}

// Shepperd's method: a quaternion for a rotation matrix (the test's own, not core's).
std::array<double, 4> toQuaternion(const Mat& m) {
  const double tr = m[0][0] + m[1][1] + m[2][2];
  double w, x, y, z;
  if (tr > 0) {
    const double s = std::sqrt(tr + 1.0) * 2;
    w = 0.25 * s, x = (m[2][1] - m[1][2]) / s, y = (m[0][2] - m[2][0]) / s, z = (m[1][0] - m[0][1]) / s;
  } else if (m[0][0] > m[1][1] && m[0][0] > m[2][2]) {
    const double s = std::sqrt(1.0 + m[0][0] - m[1][1] - m[2][2]) * 2;
    w = (m[2][1] - m[1][2]) / s, x = 0.25 * s, y = (m[0][1] + m[1][0]) / s, z = (m[0][2] + m[2][0]) / s;
  } else if (m[1][1] > m[2][2]) {
    const double s = std::sqrt(1.0 + m[1][1] - m[0][0] - m[2][2]) * 2;
    w = (m[0][2] - m[2][0]) / s, x = (m[0][1] + m[1][0]) / s, y = 0.25 * s, z = (m[1][2] + m[2][1]) / s;
  } else {
    const double s = std::sqrt(1.0 + m[2][2] - m[0][0] - m[1][1]) * 2;
    w = (m[1][0] - m[0][1]) / s, x = (m[0][2] + m[2][0]) / s, y = (m[1][2] + m[2][1]) / s, z = 0.25 * s;
  }
  return {w, x, y, z};
}

Mat rodrigues(double rx, double ry, double rz) {
  const double t = std::sqrt(rx * rx + ry * ry + rz * rz);
  Mat r{{{1, 0, 0}, {0, 1, 0}, {0, 0, 1}}};
  if (t < 1e-15) return r;
  const double kx = rx / t, ky = ry / t, kz = rz / t;
  const Mat k{{{0, -kz, ky}, {kz, 0, -kx}, {-ky, kx, 0}}};
  const Mat k2 = mul(k, k);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r[i][j] += std::sin(t) * k[i][j] + (1 - std::cos(t)) * k2[i][j];
  return r;
}

double maxDiff(const Mat& a, const Mat& b) {
  double d = 0;
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) d = std::max(d, std::abs(a[i][j] - b[i][j]));
  return d;
}

std::vector<double> numbers(std::string s) {
  while (!s.empty() && (s.back() == '\n' || s.back() == '\r' || s.back() == ')')) s.pop_back();
  if (!s.empty() && s.front() == '(') s.erase(0, 1);
  std::vector<double> out;
  std::size_t pos = 0;
  for (;;) {
    const std::size_t comma = s.find(',', pos);
    out.push_back(std::stod(s.substr(pos, comma - pos)));
    if (comma == std::string::npos) break;
    pos = comma + 1;
  }
  return out;
}

Pose poseOf(const Mat& m) {
  const auto q = toQuaternion(m);
  return Pose{100, -200, 300, q[0], q[1], q[2], q[3]};
}

// Decimals on the wire bound the round-trip error: 0.0005 deg (abb, fanuc), 0.0005
// mdeg-rounding in binary (0.0005 deg), 5e-7 rad (ur). Matrix entries move by at most that
// much per angle, summed over three angles.
constexpr double kTolDeg = 3 * rad(0.0005) + 1e-9;
constexpr double kTolUr = 3 * 5e-7 + 1e-9;

void checkAllDialects(const Mat& expected, const std::string& what) {
  const Pose p = poseOf(expected);
  // Quaternion -> matrix by the test's own formula agrees first (sanity of poseOf).
  ASSERT_LT(maxDiff(fromQuaternion(p.qw, p.qx, p.qy, p.qz), expected), 1e-12) << what;

  RobotReply r;
  r.cycleId = 1;
  r.pose = p;
  const auto abb = numbers(formatReply(Dialect::Abb, r));  // rz, ry, rx
  ASSERT_EQ(abb.size(), 8u) << what;
  EXPECT_LT(maxDiff(zyxDeg(abb[5], abb[6], abb[7]), expected), kTolDeg) << what << " abb";
  EXPECT_LE(std::abs(abb[6]), 90.0) << what;

  const auto fanuc = numbers(formatReply(Dialect::Fanuc, r));  // W, P, R
  ASSERT_EQ(fanuc.size(), 8u) << what;
  EXPECT_LT(maxDiff(zyxDeg(fanuc[7], fanuc[6], fanuc[5]), expected), kTolDeg) << what << " fanuc";
  EXPECT_DOUBLE_EQ(fanuc[2], 100.0);

  const auto ur = numbers(formatReply(Dialect::Ur, r));
  ASSERT_EQ(ur.size(), 8u) << what;
  EXPECT_LT(maxDiff(rodrigues(ur[5], ur[6], ur[7]), expected), kTolUr) << what << " ur";
  EXPECT_LE(std::sqrt(ur[5] * ur[5] + ur[6] * ur[6] + ur[7] * ur[7]), kPi + 1e-6) << what;
  EXPECT_DOUBLE_EQ(ur[2], 0.1);

  const std::string bin = formatReply(Dialect::Binary, r);
  const double w = binary::readInt32(bin, 28) / 1000.0, pp = binary::readInt32(bin, 32) / 1000.0,
               rr = binary::readInt32(bin, 36) / 1000.0;
  EXPECT_LT(maxDiff(zyxDeg(rr, pp, w), expected), kTolDeg) << what << " binary";
  EXPECT_EQ(binary::readInt32(bin, 16), 100000);  // µm

  auto frame = formatStrictPoseFrame(p);
  ASSERT_TRUE(frame) << what;
  const auto st = numbers(*frame);
  ASSERT_EQ(st.size(), 6u);
  EXPECT_LT(maxDiff(rodrigues(st[3], st[4], st[5]), expected), kTolUr) << what << " strict";
}

TEST(robot_rotation, SpecialAndSingularCases) {
  struct Case {
    double rz, ry, rx;
  };
  const std::vector<Case> cases = {
      {0, 0, 0},          {180, 0, 0},      {-180, 0, 0},      {0, 0, 180},       {0, 180, 0},     {90, 0, 180},
      {0, 90, 0},         {0, -90, 0},      {30, 90, 40},      {-120, -90, 75},   {45, 89.9999, 10}, {10, -89.9999, -20},
      {179.9999, 0, 0},   {-179.9999, 0, 0}, {0, 0, 179.9999}, {120, 60, -170},   {1e-7, 0, 0},    {0, 1e-9, -1e-9},
  };
  for (const Case& c : cases) checkAllDialects(zyxDeg(c.rz, c.ry, c.rx), fmt::format("{}/{}/{}", c.rz, c.ry, c.rx));
  // Half turns about oblique axes: the rotation vector's sign is free, the rotation is not.
  for (const auto& axis : std::vector<std::array<double, 3>>{{1, 1, 0}, {0, 1, -1}, {1, -2, 3}}) {
    const double n = std::sqrt(axis[0] * axis[0] + axis[1] * axis[1] + axis[2] * axis[2]);
    checkAllDialects(rodrigues(kPi * axis[0] / n, kPi * axis[1] / n, kPi * axis[2] / n), "half turn");
  }
}

TEST(robot_rotation, RandomRotationsRoundTrip) {
  std::mt19937 rng(2024);
  std::uniform_real_distribution<double> a(-180.0, 180.0), b(-90.0, 90.0);
  for (int i = 0; i < 2000; ++i) checkAllDialects(zyxDeg(a(rng), b(rng), a(rng)), "random " + std::to_string(i));
}

// The wire values themselves against the hand formulas: Euler angles printed by abb and
// fanuc equal the input for non-singular angles inside the canonical ranges.
TEST(robot_rotation, EulerAnglesComeBackUnchanged) {
  RobotReply r;
  r.pose = poseOf(zyxDeg(-12.5, 33.25, 170.0));
  const auto abb = numbers(formatReply(Dialect::Abb, r));
  EXPECT_DOUBLE_EQ(abb[5], -12.5);
  EXPECT_DOUBLE_EQ(abb[6], 33.25);
  EXPECT_DOUBLE_EQ(abb[7], 170.0);
  const auto fanuc = numbers(formatReply(Dialect::Fanuc, r));
  EXPECT_DOUBLE_EQ(fanuc[5], 170.0);  // W
  EXPECT_DOUBLE_EQ(fanuc[6], 33.25);  // P
  EXPECT_DOUBLE_EQ(fanuc[7], -12.5);  // R
}

}  // namespace
}  // namespace vgr::protocol
