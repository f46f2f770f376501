// The robot keys of cell.yaml (config/cell_config.hpp): dialects, job, max_clients,
// allowed_clients, part_order/label and the strict section; errors keep the
// "FILE:LINE: key 'a.b': ..." form.
#include <gtest/gtest.h>

#include <string>

#include "config/cell_config.hpp"

namespace {

using vgr::config::parseCellConfig;

std::string cell(const std::string& robots, const std::string& jobs = "  - {id: 1}\n  - {id: 4}\n") {
  return "camera: {address: 127.0.0.1}\nmodel: {fx: 1000}\nmodbus: {enabled: false}\nrobots:\n" + robots + "jobs:\n" + jobs;
}

TEST(robot_config, EveryDialectAndTheNewKeys) {
  auto c = parseCellConfig(cell(R"(  - {name: m20, dialect: fanuc, port: 50012, job: 4, max_clients: 1, allowed_clients: [192.168.1.20, "fe80::1"]}
  - {name: cap, dialect: binary, port: 50014, part_order: by_label}
  - name: ur5
    dialect: strict
    port: 50013
    part_order: label_only
    label: 3
    strict: {command: Pick, ready: Pick_wait, done: Pick_ok, line_end: crlf, step_timeout_ms: 20000}
  - {name: irb, dialect: abb, port: 50011}
)"),
                           "cell.yaml");
  ASSERT_TRUE(c) << c.error().message;
  ASSERT_EQ(c->robots.size(), 4u);
  const auto& f = c->robots[0];
  EXPECT_EQ(f.dialect, vgr::config::Dialect::Fanuc);
  EXPECT_EQ(f.job, 4);
  EXPECT_EQ(f.maxClients, 1);
  EXPECT_EQ(f.allowedClients, (std::vector<std::string>{"192.168.1.20", "fe80::1"}));
  EXPECT_EQ(c->robots[1].dialect, vgr::config::Dialect::Binary);
  EXPECT_EQ(c->robots[1].partOrder, vgr::config::PartOrder::ByLabel);
  EXPECT_EQ(c->robots[1].job, 0);  // default: the cell's first job
  const auto& s = c->robots[2];
  EXPECT_EQ(s.dialect, vgr::config::Dialect::Strict);
  EXPECT_EQ(s.partOrder, vgr::config::PartOrder::LabelOnly);
  EXPECT_EQ(s.label, 3);
  EXPECT_EQ(s.strict.command, "Pick");
  EXPECT_EQ(s.strict.ready, "Pick_wait");
  EXPECT_EQ(s.strict.done, "Pick_ok");
  EXPECT_EQ(s.strict.lineEnd, "\r\n");
  EXPECT_EQ(s.strict.stepTimeoutMs, 20000);
  // Defaults: the paper's tokens.
  EXPECT_EQ(c->robots[3].strict.command, "MoveJ_pose");
  EXPECT_EQ(c->robots[3].strict.ready, "MoveJ_pose_wait_pos");
  EXPECT_EQ(c->robots[3].strict.done, "MoveJ_pose_done");
  EXPECT_EQ(c->robots[3].strict.lineEnd, "");
  for (auto d : {vgr::config::Dialect::Ur, vgr::config::Dialect::Abb, vgr::config::Dialect::Fanuc,
                 vgr::config::Dialect::Binary, vgr::config::Dialect::Strict})
    EXPECT_NE(std::string(vgr::config::dialectName(d)), "?");
}

// Paper 002's random selection and the label in the replies (docs/protocols.md).
TEST(robot_config, RandomOrderAndReplyLabel) {
  auto c = parseCellConfig(cell(R"(  - {name: a, port: 50010, part_order: random, reply_label: true}
  - {name: b, dialect: fanuc, port: 50012}
)"),
                           "cell.yaml");
  ASSERT_TRUE(c) << c.error().message;
  EXPECT_EQ(c->robots[0].partOrder, vgr::config::PartOrder::Random);
  EXPECT_TRUE(c->robots[0].replyLabel);
  EXPECT_FALSE(c->robots[1].replyLabel);  // default: replies as before
}

TEST(robot_config, ErrorsNameFileLineAndKey) {
  struct Bad {
    std::string robots;
    std::string message;
  };
  const std::vector<Bad> bad = {
      {"  - {name: a, port: 1}\n  - {name: b, port: 2, job: 3}\n",
       "cell.yaml:6: key 'robots[1].job': no job with id 3 in jobs"},
      {"  - {name: a, port: 1, allowed_clients: [robot.local]}\n",
       "cell.yaml:5: key 'robots[0].allowed_clients[0]': expected a numeric IP address, got 'robot.local'"},
      {"  - {name: a, port: 1, part_order: shuffled}\n",
       "cell.yaml:5: key 'robots[0].part_order': out of range: expected one of: best_score, by_label, label_only, random, got 'shuffled'"},
      {"  - {name: a, port: 1, reply_label: yes please}\n",
       "cell.yaml:5: key 'robots[0].reply_label': expected true or false, got 'yes please'"},
      {"  - {name: a, port: 1, dialect: strict, reply_label: true}\n",
       "cell.yaml:5: key 'robots[0].reply_label': the strict dialect's pose frame has no room for a label (paper 002's six values)"},
      {"  - {name: a, port: 1, dialect: abb, abb_rotation: quaternion, reply_label: true}\n",
       "cell.yaml:5: key 'robots[0].reply_label': abb_rotation quaternion leaves no room for the label within RAPID's 80 "
       "characters; use abb_rotation zyx"},
      {"  - {name: a, port: 1, part_order: label_only}\n",
       "cell.yaml:5: key 'robots[0].label': part_order label_only needs a label"},
      {"  - {name: a, port: 1, strict: {command: X}}\n", "cell.yaml:5: key 'robots[0].strict': only for dialect strict"},
      {"  - {name: a, port: 1, dialect: strict, strict: {ready: has space}}\n",
       "cell.yaml:5: key 'robots[0].strict.ready': out of range: expected 1 to 64 printable characters without spaces, ',' or '#', got 'has space'"},
      {"  - {name: a, port: 1, dialect: strict, strict: {ready: A, done: A}}\n",
       "cell.yaml:5: key 'robots[0].strict.done': must differ from ready"},
      {"  - {name: a, port: 1, dialect: strict, strict: {step_timeout_ms: 10}}\n",
       "cell.yaml:5: key 'robots[0].strict.step_timeout_ms': out of range: expected [50, 600000], got '10'"},
      {"  - {name: a, port: 1, dialect: strict, strict: {line_end: cr}}\n",
       "cell.yaml:5: key 'robots[0].strict.line_end': out of range: expected one of: none, lf, crlf, got 'cr'"},
      {"  - {name: a, port: 1, max_clients: 0}\n", "cell.yaml:5: key 'robots[0].max_clients': out of range: expected [1, 64], got '0'"},
      {"  - {name: a, port: 1, dialect: kuka}\n",
       "cell.yaml:5: key 'robots[0].dialect': out of range: expected one of: ur, abb, fanuc, binary, strict, got 'kuka'"},
  };
  for (const Bad& b : bad) {
    auto c = parseCellConfig(cell(b.robots), "cell.yaml");
    ASSERT_FALSE(c) << b.robots;
    EXPECT_EQ(c.error().message, b.message);
  }
}

}  // namespace
