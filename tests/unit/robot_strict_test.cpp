// The strict exchange state machine (protocol/robot_strict.hpp, paper 002's MoveJ_pose
// handshake): the happy path with every framing a robot program may use, and each way it
// can go wrong.
#include <gtest/gtest.h>

#include <string>

#include "protocol/robot_strict.hpp"

namespace vgr::protocol {
namespace {

using Kind = StrictExchange::EventKind;
const std::string kFrame = "(0.512300,-0.120050,0.035000,0.000000,0.000000,-0.218166)";

TEST(robot_strict, PaperSequence) {
  StrictExchange x{StrictTokens{}};
  EXPECT_EQ(x.step(), StrictExchange::Step::Idle);
  EXPECT_EQ(x.begin(kFrame), "MoveJ_pose");
  EXPECT_EQ(x.step(), StrictExchange::Step::AwaitReady);
  x.feed("MoveJ_pose_wait_pos");
  auto e = x.poll();
  ASSERT_EQ(e.kind, Kind::SendPose);
  EXPECT_EQ(e.bytes, kFrame);
  EXPECT_EQ(x.poll().kind, Kind::None);
  EXPECT_EQ(x.step(), StrictExchange::Step::AwaitDone);
  x.feed("MoveJ_pose_done");
  EXPECT_EQ(x.poll().kind, Kind::Completed);
  EXPECT_EQ(x.step(), StrictExchange::Step::Idle);
}

TEST(robot_strict, TokensSplitAcrossReadsAndWithLineEnds) {
  StrictTokens t;
  t.lineEnd = "\n";
  StrictExchange x{t};
  EXPECT_EQ(x.begin(kFrame), "MoveJ_pose\n");
  for (char c : std::string("MoveJ_pose_wa")) {
    x.feed(std::string_view(&c, 1));
    EXPECT_EQ(x.poll().kind, Kind::None);
  }
  x.feed("it_pos\r\n");
  auto e = x.poll();
  ASSERT_EQ(e.kind, Kind::SendPose);
  EXPECT_EQ(e.bytes, kFrame + "\n");
  x.feed("\nMoveJ_pose_done#");
  EXPECT_EQ(x.poll().kind, Kind::Completed);
  EXPECT_EQ(x.poll().kind, Kind::None);
}

TEST(robot_strict, ConfigurableTokens) {
  StrictExchange x{StrictTokens{"PICK", "PICK_READY", "PICK_OK", "\r\n", "", "MoveJ_none"}};
  EXPECT_EQ(x.begin("(1,2,3,4,5,6)"), "PICK\r\n");
  x.feed("MoveJ_pose_wait_pos\n");  // the default token is wrong here
  auto e = x.poll();
  ASSERT_EQ(e.kind, Kind::Failed);
  EXPECT_EQ(e.status, Status::UnknownCommand);
  EXPECT_EQ(e.detail, "expected 'PICK_READY', got 'MoveJ_pose_wait_pos'");
  EXPECT_EQ(x.begin("(1,2,3,4,5,6)"), "PICK\r\n");
  x.feed("PICK_READY\r\n");
  EXPECT_EQ(x.poll().kind, Kind::SendPose);
  x.feed("PICK_OK\r\n");
  EXPECT_EQ(x.poll().kind, Kind::Completed);
}

TEST(robot_strict, WrongTokenAtEachStep) {
  {
    StrictExchange x{StrictTokens{}};
    x.begin(kFrame);
    x.feed("MoveJ_pose_done\n");  // skipped a step
    auto e = x.poll();
    ASSERT_EQ(e.kind, Kind::Failed);
    EXPECT_EQ(e.status, Status::UnknownCommand);
    EXPECT_EQ(e.detail, "expected 'MoveJ_pose_wait_pos', got 'MoveJ_pose_done'");
    EXPECT_EQ(x.step(), StrictExchange::Step::Idle);
  }
  {
    StrictExchange x{StrictTokens{}};
    x.begin(kFrame);
    x.feed("MoveJ_pose_wait_pos");
    ASSERT_EQ(x.poll().kind, Kind::SendPose);
    x.feed("MoveJ_pose_error\n");
    auto e = x.poll();
    ASSERT_EQ(e.kind, Kind::Failed);
    EXPECT_EQ(e.detail, "expected 'MoveJ_pose_done', got 'MoveJ_pose_error'");
  }
  {
    // A longer word that starts with the token is not the token.
    StrictExchange x{StrictTokens{}};
    x.begin(kFrame);
    x.feed("MoveJ_pose_wait_pos2\n");
    auto e = x.poll();
    ASSERT_EQ(e.kind, Kind::Failed);
    EXPECT_EQ(e.detail, "expected 'MoveJ_pose_wait_pos', got 'MoveJ_pose_wait_pos2'");
  }
  {
    // Binary junk is quoted printably.
    StrictExchange x{StrictTokens{}};
    x.begin(kFrame);
    x.feed(std::string("\x01\xff", 2));
    auto e = x.poll();
    ASSERT_EQ(e.kind, Kind::Failed);
    EXPECT_EQ(e.detail, "expected 'MoveJ_pose_wait_pos', got '\\x01\\xff'");
  }
}

TEST(robot_strict, SilenceAndDisconnect) {
  StrictExchange x{StrictTokens{}};
  EXPECT_EQ(x.onTimeout().kind, Kind::None);  // idle: nothing to time out
  x.begin(kFrame);
  x.feed("MoveJ_pose_wa");
  x.poll();
  auto t = x.onTimeout();
  ASSERT_EQ(t.kind, Kind::Failed);
  EXPECT_EQ(t.status, Status::ProcessingTimeout);
  EXPECT_EQ(t.detail, "no 'MoveJ_pose_wait_pos' within the step timeout (received 'MoveJ_pose_wa')");

  x.begin(kFrame);
  x.feed("MoveJ_pose_wait_pos\n");
  ASSERT_EQ(x.poll().kind, Kind::SendPose);
  auto c = x.onClosed();
  ASSERT_EQ(c.kind, Kind::Failed);
  EXPECT_EQ(c.status, Status::Internal);
  EXPECT_EQ(c.detail, "connection lost while waiting for 'MoveJ_pose_done'");
  EXPECT_EQ(x.onClosed().kind, Kind::None);
}

TEST(robot_strict, BytesWhileIdleAreReportedAndDropped) {
  StrictExchange x{StrictTokens{}};
  x.feed("hello\n");
  auto e = x.poll();
  ASSERT_EQ(e.kind, Kind::Unexpected);
  EXPECT_EQ(e.detail, "hello\\x0a");
  EXPECT_EQ(x.poll().kind, Kind::None);
  x.begin(kFrame);
  x.feed("MoveJ_pose_wait_pos");
  EXPECT_EQ(x.poll().kind, Kind::SendPose);
}

}  // namespace
}  // namespace vgr::protocol
