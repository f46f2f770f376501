// job.yaml's `classify:` section (config/job.hpp, docs/classification.md): read and validated
// through the one YAML section reader, written back only when set, errors naming the line.
#include <string>

#include <gtest/gtest.h>

#include "config/job.hpp"

namespace {

const std::string kHead = "version: 1\nname: j\nmethod: moments\ntemplate: template.png\ngrasps: [{x_px: 1, y_px: 2}]\n";

TEST(ClassifyJob, ReadsValidatesAndRoundTrips) {
  auto j = vgr::config::parseJob(kHead + "classify: {model: c.yaml, min_confidence: 0.9, max_feature_z: 5, threshold: 70, keep_unknown: true}\n",
                                 "J/job.yaml", "J");
  ASSERT_TRUE(j.has_value()) << j.error().message;
  EXPECT_EQ(j->classify.model, "c.yaml");
  EXPECT_DOUBLE_EQ(j->classify.minConfidence, 0.9);
  EXPECT_DOUBLE_EQ(j->classify.maxFeatureZ, 5);
  EXPECT_EQ(j->classify.threshold, 70);
  EXPECT_TRUE(j->classify.keepUnknown);
  EXPECT_EQ(j->classifierPath(), "J/c.yaml");
  auto back = vgr::config::parseJob(vgr::config::jobYaml(*j), "J/job.yaml", "J");
  ASSERT_TRUE(back.has_value()) << back.error().message;
  EXPECT_EQ(back->classify.model, "c.yaml");
  EXPECT_DOUBLE_EQ(back->classify.minConfidence, 0.9);
  EXPECT_EQ(back->classify.threshold, 70);
  EXPECT_TRUE(back->classify.keepUnknown);

  // Defaults, and no classify section written for a job without a classifier.
  auto plain = vgr::config::parseJob(kHead, "J/job.yaml", "J");
  ASSERT_TRUE(plain.has_value());
  EXPECT_TRUE(plain->classify.model.empty());
  EXPECT_TRUE(plain->classifierPath().empty());
  EXPECT_EQ(vgr::config::jobYaml(*plain).find("classify"), std::string::npos);
  auto defaults = vgr::config::parseJob(kHead + "classify: {model: c.yaml}\n", "J/job.yaml", "J");
  ASSERT_TRUE(defaults.has_value());
  EXPECT_DOUBLE_EQ(defaults->classify.minConfidence, 0.8);
  EXPECT_FALSE(defaults->classify.keepUnknown);
}

TEST(ClassifyJob, BadValuesNameFileLineAndKey) {
  auto bad = vgr::config::parseJob(kHead + "classify:\n  model: c.yaml\n  min_confidence: 1.5\n", "J/job.yaml", "J");
  ASSERT_FALSE(bad.has_value());
  EXPECT_NE(bad.error().message.find("J/job.yaml:8"), std::string::npos) << bad.error().message;
  EXPECT_NE(bad.error().message.find("classify.min_confidence"), std::string::npos) << bad.error().message;
  auto unknown = vgr::config::parseJob(kHead + "classify:\n  model: c.yaml\n  min_confidense: 0.9\n", "J/job.yaml", "J");
  ASSERT_FALSE(unknown.has_value());
  EXPECT_NE(unknown.error().message.find("min_confidense"), std::string::npos) << unknown.error().message;
  auto noModel = vgr::config::parseJob(kHead + "classify: {min_confidence: 0.9}\n", "J/job.yaml", "J");
  ASSERT_FALSE(noModel.has_value());
  EXPECT_NE(noModel.error().message.find("model"), std::string::npos) << noModel.error().message;
}

}  // namespace
