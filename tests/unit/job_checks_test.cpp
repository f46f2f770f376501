// Checks that check (no silent wrong answers): a job field that cannot be right for its
// template is refused when the job is loaded, for every reader (loadJob is what vgrd's
// cell config, `vgr locate`, `vgr eval` and `vgr check` go through).
#include <unistd.h>

#include <filesystem>
#include <string>

#include <fmt/core.h>
#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job.hpp"

namespace {

namespace fs = std::filesystem;

fs::path tempDir(const std::string& name) {
  const fs::path p = fs::temp_directory_path() / fmt::format("vgr-job-checks-{}-{}", name, ::getpid());
  fs::remove_all(p);
  fs::create_directories(p);
  return p;
}

// A job folder with a 324 x 200 px template and one grasp point.
vgr::config::JobFile jobWithTemplate(const fs::path& dir, double graspX, double graspY, const std::string& image = "template.png") {
  cv::imwrite((dir / image).string(), cv::Mat(200, 324, CV_8UC1, cv::Scalar(80)));
  vgr::config::JobFile j;
  j.folder = dir.string();
  j.method = "shape";
  j.templateImage = image;
  j.grasps = {{graspX, graspY}};
  j.taught.grasp = j.grasps.front();
  return j;
}

TEST(job_checks, GraspOutsideTheTemplateIsRefusedOnLoad) {
  const fs::path dir = tempDir("grasp");
  ASSERT_TRUE(vgr::config::writeJob(jobWithTemplate(dir, 9999, 50)).has_value());
  auto job = vgr::config::loadJob(dir.string());
  ASSERT_FALSE(job.has_value()) << "a grasp at x = 9999 on a 324 px template loaded";
  EXPECT_NE(job.error().message.find((dir / "job.yaml").string() + ":"), std::string::npos) << job.error().message;
  EXPECT_NE(job.error().message.find("key 'grasps[0].x_px'"), std::string::npos) << job.error().message;
  EXPECT_NE(job.error().message.find("324x200"), std::string::npos) << job.error().message;
  fs::remove_all(dir);
}

TEST(job_checks, GraspOutsideAJpegTemplateIsRefusedToo) {
  const fs::path dir = tempDir("jpeg");
  ASSERT_TRUE(vgr::config::writeJob(jobWithTemplate(dir, 10, -3, "t.jpg")).has_value());
  auto job = vgr::config::loadJob(dir.string());
  ASSERT_FALSE(job.has_value());
  EXPECT_NE(job.error().message.find("key 'grasps[0].y_px'"), std::string::npos) << job.error().message;
  fs::remove_all(dir);
}

TEST(job_checks, RegionWhollyOutsideTheTemplateIsRefusedOnLoad) {
  const fs::path dir = tempDir("region");
  auto j = jobWithTemplate(dir, 100, 50);
  j.taught.regions.push_back({{{400, 0}, {500, 0}, {500, 10}}, 10, 0.1});
  ASSERT_TRUE(vgr::config::writeJob(j).has_value());
  auto job = vgr::config::loadJob(dir.string());
  ASSERT_FALSE(job.has_value());
  EXPECT_NE(job.error().message.find("key 'regions[0].polygon': lies wholly outside the 324x200 px template"), std::string::npos) << job.error().message;
  fs::remove_all(dir);
}

// `roi` is the whole image (0 x 0) or a rectangle (both sizes > 0). A half-given ROI
// (width without height, an offset with 0 x 0) used to load and search the whole image:
// the part found outside the region the operator meant.
TEST(job_checks, AHalfGivenSearchRoiIsRefusedOnLoad) {
  const fs::path dir = tempDir("roi");
  const struct {
    vgr::PixelRect roi;
    bool loads;
  } cases[] = {{{0, 0, 0, 0}, true}, {{10, 20, 300, 200}, true}, {{0, 0, 100, 0}, false}, {{0, 0, 0, 80}, false}, {{10, 20, 0, 0}, false}};
  for (const auto& c : cases) {
    auto j = jobWithTemplate(dir, 100, 50);
    j.taught.searchRoi = c.roi;
    ASSERT_TRUE(vgr::config::writeJob(j).has_value());
    auto job = vgr::config::loadJob(dir.string());
    const std::string what = fmt::format("roi {},{} {}x{}", c.roi.x, c.roi.y, c.roi.width, c.roi.height);
    EXPECT_EQ(job.has_value(), c.loads) << what << (job ? "" : ": " + job.error().message);
    if (!c.loads && !job) {
      EXPECT_NE(job.error().message.find((dir / "job.yaml").string() + ":"), std::string::npos) << job.error().message;
      EXPECT_NE(job.error().message.find("key 'roi"), std::string::npos) << job.error().message;
    }
  }
  fs::remove_all(dir);
}

TEST(job_checks, AGraspOnTheTemplateLoads) {
  const fs::path dir = tempDir("ok");
  ASSERT_TRUE(vgr::config::writeJob(jobWithTemplate(dir, 323, 199)).has_value());
  auto job = vgr::config::loadJob(dir.string());
  ASSERT_TRUE(job.has_value()) << job.error().message;
  fs::remove_all(dir);
}

}  // namespace
