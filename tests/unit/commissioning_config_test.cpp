// The commissioning keys of the cell config (config/cell_config.hpp, docs/commissioning.md):
// web.page / actions / allowed_clients / live_max_width and the archive section: defaults,
// addresses normalised, actions without an allow-list refused, errors naming file:line:key.
#include "config/cell_config.hpp"

#include <gtest/gtest.h>

#include <string>

namespace vgr::config {
namespace {

Result<CellConfig> withTail(const std::string& tail) {
  return parseCellConfig(embeddedSimCellYaml() + "\n" + tail, "/etc/vgr/cell.yaml");
}

TEST(commissioning_config, PageOnActionsOffByDefault) {
  const auto c = withTail("web:\n  port: 8080\n");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_TRUE(c->web.page);
  EXPECT_FALSE(c->web.actions);
  EXPECT_TRUE(c->web.allowedClients.empty());
  EXPECT_EQ(c->web.liveMaxWidth, 1280);
  EXPECT_FALSE(c->archive.enabled);
}

TEST(commissioning_config, ActionsNeedAnAllowListOfAddresses) {
  const auto ok = withTail("web:\n  actions: true\n  allowed_clients: [10.0.0.7, '::ffff:10.0.0.8', 0:0:0:0:0:0:0:1]\n");
  ASSERT_TRUE(ok.has_value()) << ok.error().message;
  EXPECT_TRUE(ok->web.actions);
  EXPECT_EQ(ok->web.allowedClients, (std::vector<std::string>{"10.0.0.7", "::ffff:10.0.0.8", "::1"}));
  const auto none = withTail("web:\n  actions: true\n");
  ASSERT_FALSE(none.has_value());
  EXPECT_NE(none.error().message.find("key 'web.actions'"), std::string::npos) << none.error().message;
  EXPECT_NE(none.error().message.find("allowed_clients"), std::string::npos) << none.error().message;
  const auto name = withTail("web:\n  actions: true\n  allowed_clients: [operator-pc]\n");
  ASSERT_FALSE(name.has_value());
  EXPECT_NE(name.error().message.find("key 'web.allowed_clients[0]'"), std::string::npos) << name.error().message;
  const auto noPage = withTail("web:\n  page: false\n  actions: true\n  allowed_clients: [10.0.0.7]\n");
  ASSERT_FALSE(noPage.has_value());
  const auto width = withTail("web:\n  live_max_width: 20\n");
  ASSERT_FALSE(width.has_value());
  EXPECT_NE(width.error().message.find("key 'web.live_max_width'"), std::string::npos) << width.error().message;
}

TEST(commissioning_config, ArchiveSection) {
  const auto d = withTail("archive:\n");
  ASSERT_TRUE(d.has_value()) << d.error().message;
  EXPECT_FALSE(d->archive.enabled) << "an empty section is absent";
  const auto c = withTail("archive:\n  quota_mb: 20\n  every_nth_good: 10\n  queue: 4\n  dir: frames\n");
  ASSERT_TRUE(c.has_value()) << c.error().message;
  EXPECT_TRUE(c->archive.enabled);
  EXPECT_EQ(c->archive.quotaBytes, 20'000'000u);
  EXPECT_EQ(c->archive.everyNthGood, 10);
  EXPECT_EQ(c->archive.queue, 4);
  EXPECT_EQ(c->archive.dir, "/etc/vgr/frames") << "relative to the config file's folder";
  const auto defaults = withTail("archive:\n  enabled: true\n");
  ASSERT_TRUE(defaults.has_value());
  EXPECT_EQ(defaults->archive.quotaBytes, 1'000'000'000u);
  EXPECT_EQ(defaults->archive.everyNthGood, 100);
  EXPECT_EQ(defaults->archive.dir, "") << "resolved at start: next to the journal";
  for (const char* bad : {"archive:\n  quota_mb: 0\n", "archive:\n  queue: 100\n", "archive:\n  every_nth_good: -1\n",
                          "archive:\n  qouta_mb: 5\n"}) {
    const auto r = withTail(bad);
    ASSERT_FALSE(r.has_value()) << bad;
    EXPECT_NE(r.error().message.find("/etc/vgr/cell.yaml:"), std::string::npos) << r.error().message;
    EXPECT_NE(r.error().message.find("key 'archive."), std::string::npos) << r.error().message;
  }
}

}  // namespace
}  // namespace vgr::config
