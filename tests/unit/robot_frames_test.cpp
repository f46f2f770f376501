// What a robot endpoint receives for a part (protocol/robot_frames.hpp, docs/protocols.md
// "Offsets and frames"): the pose in a user frame, the displacement offset of abb / fanuc /
// binary and the pose_trans offset of ur / strict, checked by applying each the way the
// robot language does (written out here with plain rotation matrices, not the code under
// test), and through ResultStore::replies and the dialect codecs down to the bytes.
#include <gtest/gtest.h>

#include <array>
#include <cmath>
#include <set>

#include <boost/asio/io_context.hpp>

#include "core/pose.hpp"
#include "daemon/result_store.hpp"
#include "protocol/robot_codec.hpp"
#include "protocol/robot_frames.hpp"

namespace vgr::protocol {
namespace {

constexpr double kPi = 3.14159265358979323846;
using Mat = std::array<std::array<double, 4>, 4>;

// Homogeneous matrix of R = Rz(rz) Ry(ry) Rx(rx) (degrees) at t, written out.
Mat zyx(double x, double y, double z, double rzDeg, double ryDeg, double rxDeg) {
  const double a = rzDeg * kPi / 180, b = ryDeg * kPi / 180, c = rxDeg * kPi / 180;
  const double ca = std::cos(a), sa = std::sin(a), cb = std::cos(b), sb = std::sin(b), cc = std::cos(c), sc = std::sin(c);
  return {{{ca * cb, ca * sb * sc - sa * cc, ca * sb * cc + sa * sc, x},
           {sa * cb, sa * sb * sc + ca * cc, sa * sb * cc - ca * sc, y},
           {-sb, cb * sc, cb * cc, z},
           {0, 0, 0, 1}}};
}
Mat mul(const Mat& a, const Mat& b) {
  Mat m{};
  for (int i = 0; i < 4; ++i)
    for (int j = 0; j < 4; ++j)
      for (int k = 0; k < 4; ++k) m[i][j] += a[i][k] * b[k][j];
  return m;
}
// A Pose as a matrix, from its quaternion (the textbook formula).
Mat matOf(const Pose& p) {
  const double w = p.qw, x = p.qx, y = p.qy, z = p.qz;
  return {{{1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w), p.x},
           {2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w), p.y},
           {2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y), p.z},
           {0, 0, 0, 1}}};
}
void expectSame(const Mat& a, const Mat& b, const char* what) {
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 4; ++j) EXPECT_NEAR(a[i][j], b[i][j], j == 3 ? 1e-9 : 1e-12) << what << " [" << i << "][" << j << "]";
}

// The sim cell's example frames: a work object at (400, -200, 0) turned 90 deg, a reference
// part at (400, 0, 0), a part shifted and turned, a little tilted.
const Mat kU = zyx(400, -200, 0, 90, 0, 0);
const Mat kR = zyx(400, 0, 0, 0, 0, 0);
const Mat kP = zyx(437.25, 18.5, 2.0, 31.0, 0.4, -0.3);
const Pose U = poseFromEulerZyxDeg(400, -200, 0, EulerZyxDeg{90, 0, 0});
const Pose R = poseFromEulerZyxDeg(400, 0, 0, EulerZyxDeg{0, 0, 0});
const Pose P = poseFromEulerZyxDeg(437.25, 18.5, 2.0, EulerZyxDeg{31.0, 0.4, -0.3});

TEST(robot_frames, PoseInTheBaseFrameIsThePartItself) {
  for (Dialect d : {Dialect::Ur, Dialect::Abb, Dialect::Fanuc, Dialect::Binary, Dialect::Strict})
    expectSame(matOf(deliveredPose(d, RobotFrame{}, R, P)), kP, "pose, base frame");
}

TEST(robot_frames, PoseInAUserFrameMapsBackThroughTheFrame) {
  // The robot moves to the delivered pose in its user frame: U * delivered = P.
  for (Dialect d : {Dialect::Ur, Dialect::Abb, Dialect::Fanuc})
    expectSame(mul(kU, matOf(deliveredPose(d, RobotFrame{Delivery::Pose, U}, R, P))), kP, "U * pose_u");
}

TEST(robot_frames, DisplacementMovesEveryTaughtPointWithThePart) {
  // abb PDispSet / fanuc Offset,PR[n]: a target G taught in the user frame with the reference
  // part there goes to U * D * G; for G = the reference itself (U^-1 R) that is the part, and
  // any other taught point keeps its place relative to the part.
  const Mat taught = mul(zyx(200, 0, 0, -90, 0, 0), zyx(12, -7, 30, 15, 0, 180));  // U^-1 R, then a grip
  const Mat grip = zyx(12, -7, 30, 15, 0, 180);
  for (Dialect d : {Dialect::Abb, Dialect::Fanuc, Dialect::Binary}) {
    EXPECT_EQ(offsetConvention(d), OffsetConvention::Displacement);
    const Mat D = matOf(deliveredPose(d, RobotFrame{Delivery::Offset, U}, R, P));
    expectSame(mul(mul(kU, D), taught), mul(kP, grip), "U D G = P grip");
  }
}

TEST(robot_frames, PoseTransOffsetIsThePartInTheReferenceFrame) {
  // ur / strict: pose_trans(ref, O) = ref * O = part, whatever user frame is configured.
  for (Dialect d : {Dialect::Ur, Dialect::Strict}) {
    EXPECT_EQ(offsetConvention(d), OffsetConvention::ReferenceRelative);
    expectSame(mul(kR, matOf(deliveredPose(d, RobotFrame{Delivery::Offset, U}, R, P))), kP, "ref * O");
    expectSame(mul(kR, matOf(deliveredPose(d, RobotFrame{Delivery::Offset, Pose{}}, R, P))), kP, "ref * O, base");
  }
}

TEST(robot_frames, PartOnTheReferenceGivesAZeroOffset) {
  for (Dialect d : {Dialect::Ur, Dialect::Abb, Dialect::Fanuc}) {
    const Pose o = deliveredPose(d, RobotFrame{Delivery::Offset, U}, R, R);
    EXPECT_NEAR(o.x, 0, 1e-9);
    EXPECT_NEAR(o.y, 0, 1e-9);
    EXPECT_NEAR(o.z, 0, 1e-9);
    EXPECT_NEAR(std::abs(o.qw), 1, 1e-12);
  }
}

// Through the result store and the codecs: a robot in offset mode gets the offset in its own
// notation. Golden bytes for a planar case worked out by hand: U = (400, -200, 0) rz 90,
// R = (400, 0, 0), P = (420, 10, 0) rz 30.
//   abb/fanuc D = (U^-1 P)(U^-1 R)^-1: U^-1 P = (210, -20) rz -60, U^-1 R = (200, 0) rz -90;
//     D = rz 30, t = (210, -20) - Rz(30) (200, 0) = (210 - 173.205, -20 - 100) = (36.795, -120)
//   ur O = R^-1 P = (20, 10, 0) rz 30 -> m and rotation vector (0, 0, 0.523599)
TEST(robot_frames, RepliesCarryTheOffsetInEachDialect) {
  boost::asio::io_context io;
  CycleResult r;
  r.cycleId = 4711;
  r.jobId = 1;
  r.status = Status::Ok;
  r.reference = poseFromEulerZyxDeg(400, 0, 0, EulerZyxDeg{0, 0, 0});
  PartResult part;
  part.pose = poseFromEulerZyxDeg(420, 10, 0, EulerZyxDeg{30, 0, 0});
  r.parts.push_back(part);
  auto reply = [&](Dialect d) {
    const daemon::RobotDelivery delivery{d, RobotFrame{Delivery::Offset, poseFromEulerZyxDeg(400, -200, 0, EulerZyxDeg{90, 0, 0})}};
    return formatReply(d, daemon::ResultStore::replies(r, daemon::RobotPolicy{}, delivery).front());
  };
  EXPECT_EQ(reply(Dialect::Abb), "0,4711,36.795,-120.000,0.000,30.000,0.000,0.000");
  EXPECT_EQ(reply(Dialect::Fanuc), "+0000,0004711,+00036.795,-00120.000,+00000.000,+000.000,+000.000,+030.000\r\n");
  EXPECT_EQ(reply(Dialect::Ur), "(0,4711,0.020000,0.010000,0.000000,0.000000,0.000000,0.523599)");
  // Pose mode in the same frame: U^-1 P.
  const daemon::RobotDelivery pose{Dialect::Abb, RobotFrame{Delivery::Pose, poseFromEulerZyxDeg(400, -200, 0, EulerZyxDeg{90, 0, 0})}};
  EXPECT_EQ(formatReply(Dialect::Abb, daemon::ResultStore::replies(r, daemon::RobotPolicy{}, pose).front()),
            "0,4711,210.000,-20.000,0.000,-60.000,0.000,0.000");
  // An out-of-limits cycle: -9 and no pose, for every dialect.
  CycleResult out = r;
  out.status = Status::OffsetOutOfLimits;
  out.rejected.push_back({out.parts.front(), "work area x 420.000 mm outside [0, 410]"});
  out.parts.clear();
  EXPECT_EQ(formatReply(Dialect::Abb, daemon::ResultStore::replies(out, daemon::RobotPolicy{}).front()),
            "-9,4711,0.000,0.000,0.000,0.000,0.000,0.000");
}

}  // namespace
}  // namespace vgr::protocol
