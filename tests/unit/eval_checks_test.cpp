// `vgr eval` cannot be fooled (tools/vgr/eval_report.hpp): a detection farther than the
// tolerance from every truth part is a miss plus a false positive, an empty data set is an
// error, and one unreadable image is reported while the rest are evaluated.
#include <unistd.h>

#include <filesystem>
#include <fstream>
#include <string>

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/job.hpp"
#include "tools/vgr/eval_report.hpp"

namespace {

namespace fs = std::filesystem;

class eval_checks : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() /
           fmt::format("vgr-eval-checks-{}-{}", ::testing::UnitTest::GetInstance()->current_test_info()->name(), ::getpid());
    fs::remove_all(dir_);
    fs::create_directories(dir_ / "job");
    fs::create_directories(dir_ / "data");
    // A moments job taught on a bright 60 x 40 px rectangle with a tab (its ends told
    // apart), grasp at (59.5, 39.5).
    cv::Mat t(80, 120, CV_8UC1, cv::Scalar(20));
    drawPart(t, 0, 0);
    cv::imwrite((dir_ / "job" / "template.png").string(), t);
    vgr::config::JobFile j;
    j.folder = (dir_ / "job").string();
    j.method = "moments";
    j.grasps = {{59.5, 39.5}};
    j.taught.grasp = j.grasps.front();
    ASSERT_TRUE(vgr::config::writeJob(j).has_value());
    options_.jobFolder = j.folder;
    options_.datasetFolder = (dir_ / "data").string();
  }
  void TearDown() override { fs::remove_all(dir_); }

  static void drawPart(cv::Mat& m, int dx, int dy) {
    cv::rectangle(m, cv::Rect(30 + dx, 20 + dy, 60, 40), cv::Scalar(220), cv::FILLED);
    cv::rectangle(m, cv::Rect(90 + dx, 20 + dy, 16, 16), cv::Scalar(220), cv::FILLED);
  }
  // A 1600 x 1200 px scene with the template's part moved by (dx, dy): its grasp point at
  // (59.5 + dx, 39.5 + dy).
  void scene(const std::string& name, int dx, int dy) {
    cv::Mat s(1200, 1600, CV_8UC1, cv::Scalar(20));
    drawPart(s, dx, dy);
    cv::imwrite((dir_ / "data" / name).string(), s);
  }
  void truth(const std::string& rows) {
    std::ofstream(dir_ / "data" / "truth.csv") << "image,x_px,y_px,angle_deg\n" << rows;
  }

  fs::path dir_;
  vgr::tools::EvalOptions options_;
};

TEST_F(eval_checks, AFarDetectionIsAMissAndAFalsePositive) {
  scene("a.png", 960, 980);  // found at (1019.5, 1019.5), 1427 px from the truth at (10, 10)
  truth("a.png,10,10,0\n");
  auto rep = vgr::tools::evaluate(options_);
  ASSERT_TRUE(rep.has_value()) << rep.error().message;
  EXPECT_EQ(rep->n, 1);
  EXPECT_EQ(rep->successes, 0);
  EXPECT_EQ(rep->missed, 1);
  EXPECT_EQ(rep->falsePositives, 1);
  EXPECT_EQ(rep->countCorrectImages, 0);
}

TEST_F(eval_checks, ANearDetectionIsMatched) {
  scene("a.png", 340, 260);
  truth("a.png,399.5,299.5,0\n");
  auto rep = vgr::tools::evaluate(options_);
  ASSERT_TRUE(rep.has_value()) << rep.error().message;
  EXPECT_EQ(rep->missed, 0);
  EXPECT_EQ(rep->falsePositives, 0);
  EXPECT_EQ(rep->countCorrectImages, 1);
}

// Errors are measured on matched parts only: with none matched there is no error to
// report, and the JSON says null, not a perfect 0.0 px / 0.0 deg.
TEST_F(eval_checks, NoMatchedPartReportsNoErrorFigures) {
  scene("a.png", 960, 980);  // found 1427 px from the truth: a miss
  truth("a.png,10,10,0\n");
  auto rep = vgr::tools::evaluate(options_);
  ASSERT_TRUE(rep.has_value()) << rep.error().message;
  const auto j = nlohmann::json::parse(vgr::tools::evalJson(*rep, options_));
  for (const char* k : {"pos_err_px_mean", "pos_err_px_max", "ang_err_deg_mean", "ang_err_deg_max"})
    EXPECT_TRUE(j[k].is_null()) << k << " = " << j[k].dump() << " with no matched part";
  EXPECT_EQ(j["success_rate"].get<double>(), 0.0);
  // With a match the figures are numbers.
  scene("a.png", 340, 260);
  truth("a.png,399.5,299.5,0\n");
  rep = vgr::tools::evaluate(options_);
  ASSERT_TRUE(rep.has_value()) << rep.error().message;
  const auto k = nlohmann::json::parse(vgr::tools::evalJson(*rep, options_));
  EXPECT_TRUE(k["pos_err_px_mean"].is_number()) << k.dump();
  EXPECT_LT(k["pos_err_px_max"].get<double>(), 1.0) << k.dump();
}

TEST_F(eval_checks, AnEmptyDatasetIsAnError) {
  truth("");
  auto rep = vgr::tools::evaluate(options_);
  ASSERT_FALSE(rep.has_value()) << "an empty data set evaluated as " << rep->n << " samples";
  EXPECT_NE(rep.error().message.find("truth.csv"), std::string::npos) << rep.error().message;
}

TEST_F(eval_checks, AnUnreadableImageIsReportedAndTheRestEvaluated) {
  scene("a.png", 340, 260);
  std::ofstream(dir_ / "data" / "b.png") << "not an image";
  truth("b.png,399.5,299.5,0\na.png,399.5,299.5,0\n");
  auto rep = vgr::tools::evaluate(options_);
  ASSERT_TRUE(rep.has_value()) << rep.error().message;
  EXPECT_EQ(rep->images, 1);
  EXPECT_EQ(rep->successes, 1);
  ASSERT_EQ(rep->unreadable.size(), 1u);
  EXPECT_NE(rep->unreadable[0].find("b.png"), std::string::npos) << rep->unreadable[0];
}

TEST_F(eval_checks, NoReadableImageIsAnError) {
  std::ofstream(dir_ / "data" / "b.png") << "not an image";
  truth("b.png,399.5,299.5,0\n");
  auto rep = vgr::tools::evaluate(options_);
  ASSERT_FALSE(rep.has_value());
  EXPECT_NE(rep.error().message.find("b.png"), std::string::npos) << rep.error().message;
}

}  // namespace
