// The robot side's reply checker (protocol/robot_reply.hpp): everything vgrd's formatReply()
// sends is accepted with its numbers, byte errors are not, and a cycle id vgrd never sends
// (negative, or 2^23 and above) is refused. The last one was found by fuzz_robot_reply: a
// binary reply with a negative cycle passed (fails before the fix, passes after).
#include <gtest/gtest.h>

#include <cmath>
#include <string>

#include "core/pose.hpp"
#include "protocol/robot_codec.hpp"
#include "protocol/robot_reply.hpp"

namespace vgr::protocol {
namespace {

RobotReply okReply() {
  RobotReply r;
  r.cycleId = 4711;
  r.pose = poseFromXyzRz(512.3, -120.05, 35.0, -12.5 * M_PI / 180.0);
  return r;
}

// reply_label replies (the sim robot's check of them, formerly its own parser): label and
// confidence come back in every dialect that carries them; the plain form is refused as a
// labelled one and the other way round; a confidence above 1 is not a reply of vgrd's.
TEST(robot_reply, LabelledRepliesRoundTrip) {
  RobotReply r = okReply();
  r.label = 17;
  r.confidence = 0.875;
  for (const Dialect d : {Dialect::Ur, Dialect::Abb, Dialect::Fanuc, Dialect::Binary}) {
    const std::string raw = formatReply(d, r, true);
    const auto p = parseRobotReply(d, raw, ReplyForm{.withLabel = true});
    ASSERT_TRUE(p.has_value()) << dialectName(d) << ": " << p.error().message << " " << raw;
    EXPECT_EQ(p->cycle, 4711);
    EXPECT_NEAR(p->xMm, 512.3, 0.0011) << dialectName(d);
    EXPECT_NEAR(p->rzDeg, -12.5, 0.0011) << dialectName(d);
    EXPECT_EQ(p->label, 17) << dialectName(d);
    EXPECT_DOUBLE_EQ(p->confidence, 0.875) << dialectName(d);
    EXPECT_FALSE(parseRobotReply(d, raw, ReplyForm{.withLabel = false})) << dialectName(d);
    EXPECT_FALSE(parseRobotReply(d, formatReply(d, r, false), ReplyForm{.withLabel = true})) << dialectName(d);
  }
  EXPECT_FALSE(parseRobotReply(Dialect::Abb, "0,4711,512.300,-120.050,35.000,-12.500,0.000,0.000,17,1.500", ReplyForm{.withLabel = true}));
  EXPECT_TRUE(parseRobotReply(Dialect::Abb, "0,4711,512.300,-120.050,35.000,-12.500,0.000,0.000,17,1.000", ReplyForm{.withLabel = true}));
}

TEST(robot_reply, EveryDialectRoundTrips) {
  for (const Dialect d : {Dialect::Ur, Dialect::Abb, Dialect::Fanuc, Dialect::Binary}) {
    const auto p = parseRobotReply(d, formatReply(d, okReply()));
    ASSERT_TRUE(p.has_value()) << dialectName(d) << ": " << p.error().message;
    EXPECT_EQ(p->status, 0);
    EXPECT_EQ(p->cycle, 4711);
    EXPECT_NEAR(p->xMm, 512.3, 0.0011) << dialectName(d);
    EXPECT_NEAR(p->yMm, -120.05, 0.0011) << dialectName(d);
    EXPECT_NEAR(p->zMm, 35.0, 0.0011) << dialectName(d);
    EXPECT_NEAR(p->rzDeg, -12.5, 0.0011) << dialectName(d);
  }
}

// Six degrees of freedom, the abb quaternion form and the label fields (issue 14; the
// reply forms vgr-sim-robot checks): every dialect gives back the pose's Z-Y-X angles.
TEST(robot_reply, SixDofQuaternionAndLabelRoundTrip) {
  RobotReply r = okReply();
  r.pose = poseFromEulerZyxDeg(512.3, -120.05, 35.0, EulerZyxDeg{-12.5, 20.25, -33.75});
  r.label = 7;
  r.confidence = 0.875;
  for (const Dialect d : {Dialect::Ur, Dialect::Abb, Dialect::Fanuc, Dialect::Binary})
    for (const bool withLabel : {false, true})
      for (const AbbRotation rot : {AbbRotation::EulerZyx, AbbRotation::Quaternion}) {
        if (d != Dialect::Abb && rot == AbbRotation::Quaternion) continue;
        const std::string what = std::string(dialectName(d)) + (withLabel ? " label" : "") +
                                 (rot == AbbRotation::Quaternion ? " quaternion" : "");
        const auto p = parseRobotReply(d, formatReply(d, r, withLabel, rot), ReplyForm{rot, withLabel});
        ASSERT_TRUE(p.has_value()) << what << ": " << p.error().message;
        EXPECT_NEAR(p->xMm, 512.3, 0.0011) << what;
        EXPECT_NEAR(p->rzDeg, -12.5, 0.003) << what;
        EXPECT_NEAR(p->ryDeg, 20.25, 0.003) << what;
        EXPECT_NEAR(p->rxDeg, -33.75, 0.003) << what;
        EXPECT_EQ(p->label, withLabel ? 7 : 0) << what;
        EXPECT_NEAR(p->confidence, withLabel ? 0.875 : 0.0, 1e-9) << what;
        // The other form is refused: a robot program reads exactly one.
        EXPECT_FALSE(parseRobotReply(d, formatReply(d, r, withLabel, rot), ReplyForm{rot, !withLabel})) << what;
      }
}

TEST(robot_reply, ByteErrorsAreRefused) {
  EXPECT_FALSE(parseRobotReply(Dialect::Ur, "(0,1,0.5,0,0,0,0,0)"));       // 6 decimals required
  EXPECT_FALSE(parseRobotReply(Dialect::Abb, "0,1,1.000,2.000,3.000,4.000,5.000,6.000 "));  // stray byte
  EXPECT_FALSE(parseRobotReply(Dialect::Fanuc, "+0000,0000001,+00001.000,+00002.000,+00003.000,+000.000,+000.000,+000.000\n"));
  EXPECT_FALSE(parseRobotReply(Dialect::Binary, std::string(39, '\0')));
  EXPECT_FALSE(parseRobotReply(Dialect::Strict, "(0.1,0.2,0.3,0,0,0)"));
}

TEST(robot_reply, CycleIdsVgrdNeverSendsAreRefused) {
  std::string frame = formatReply(Dialect::Binary, okReply());
  frame[12] = static_cast<char>(0xF9);  // cycle 0xF9FF1267: negative as int32
  frame[13] = static_cast<char>(0xFF);
  const auto negative = parseRobotReply(Dialect::Binary, frame);
  ASSERT_FALSE(negative.has_value());
  EXPECT_NE(negative.error().message.find("cycle id out of range"), std::string::npos);
  EXPECT_FALSE(parseRobotReply(Dialect::Ur, "(0,8388608,0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)"));
  EXPECT_TRUE(parseRobotReply(Dialect::Ur, "(0,8388607,0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)"));
}

// Found by the long run of fuzz_robot_reply: a ur reply with a 200-digit x passed, and was
// infinite in mm. vgrd never sends a position beyond 99999.999 mm or an angle beyond 180
// degrees (pi for a rotation vector): such a reply is refused (fails before, passes after).
TEST(robot_reply, NumbersVgrdNeverSendsAreRefused) {
  const std::string huge(200, '5');
  EXPECT_FALSE(parseRobotReply(Dialect::Ur, "(0,1," + huge + ".000000,0.000000,0.000000,0.000000,0.000000,0.000000)"));
  EXPECT_FALSE(parseRobotReply(Dialect::Ur, "(0,1,100.000001,0.000000,0.000000,0.000000,0.000000,0.000000)"));
  EXPECT_FALSE(parseRobotReply(Dialect::Ur, "(0,1,0.100000,0.000000,0.000000,0.000000,0.000000,4.000000)"));
  EXPECT_FALSE(parseRobotReply(Dialect::Abb, "0,1,1.000,2.000,3.000,181.000,0.000,0.000"));
  EXPECT_FALSE(parseRobotReply(Dialect::Abb, "100,1,1.000,2.000,3.000,1.000,0.000,0.000"));
  EXPECT_TRUE(parseRobotReply(Dialect::Abb, "-9,1,0.000,0.000,0.000,0.000,0.000,0.000"));
}

}  // namespace
}  // namespace vgr::protocol
