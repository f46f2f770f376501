// Polarity of the segmentation methods `moments` and `hu` (vision/locate/blob_polarity.hpp):
// a dark part on a light belt (the renderer's flat part, every image inverted) is taught and
// found; `polarity: use` (the default, the template's sense) finds no inverted part, and
// `ignore_global` finds both senses. The parameter is validated where the job loads, with
// the file and line, and `vgr teach --polarity` writes it.
// Failed before: teaching either method on the dark part failed ("no part found in the
// template image"), as no polarity could be chosen.
#include <cmath>
#include <filesystem>
#include <fstream>

#include <unistd.h>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job.hpp"
#include "daemon/job_locator.hpp"
#include "sim/part_scene.hpp"
#include "tools/vgr/teach.hpp"
#include "vision/locate/locator.hpp"

namespace {

using vgr::sim::PartModel;
using vgr::sim::PartSceneOptions;
using vgr::sim::PartSceneRenderer;

PartSceneRenderer scenes() {
  PartSceneOptions o;
  o.width = 800;
  o.height = 640;
  o.focalPx = 1000;
  o.angleRangeDeg = 180;
  o.noiseSigma = 3;
  o.clutter = 2;
  o.seed = 17;
  return PartSceneRenderer(PartModel::flat(), o);
}

cv::Mat inverted(const cv::Mat& img) { return cv::Scalar(255) - img; }

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

struct DarkJob {
  cv::Mat templ;  // dark part on a light belt
  vgr::vision::TaughtTemplate taught;
};

DarkJob darkJob(const PartSceneRenderer& r) {
  DarkJob j;
  cv::Mat bright;
  const auto t = r.renderTemplate(bright);
  j.templ = inverted(bright);
  j.taught.grasp = {t.graspU, t.graspV};
  return j;
}

// How many of the first n scenes (inverted when `dark`) give one part within 1.5 px / 0.5 deg.
int found(vgr::vision::Locator& loc, const PartSceneRenderer& r, bool dark, int n, int* anyPart = nullptr) {
  int ok = 0, any = 0;
  cv::Mat img;
  for (int i = 0; i < n; ++i) {
    const auto scene = r.sample(static_cast<std::uint64_t>(i));
    r.render(scene, img);
    auto out = loc.locate(dark ? inverted(img) : img);
    EXPECT_TRUE(out) << (out ? "" : out.error().message);
    if (!out || out->parts.empty()) continue;
    ++any;
    const auto& d = out->parts.front();
    const auto& t = scene.parts.at(0);
    if (std::hypot(d.u - t.uPx, d.v - t.vPx) <= 1.5 && angleDiff(d.angleDeg, t.angleDeg) <= 0.5) ++ok;
  }
  if (anyPart) *anyPart = any;
  return ok;
}

class locate_polarity : public ::testing::TestWithParam<std::string> {};

TEST_P(locate_polarity, DarkPartOnALightBeltIsTaughtAndFound) {
  const auto r = scenes();
  const DarkJob job = darkJob(r);
  auto loc = vgr::vision::makeLocator(GetParam(), job.templ, job.taught);
  ASSERT_TRUE(loc) << loc.error().message;
  EXPECT_EQ(found(**loc, r, true, 4), 4);
  // `use`: the template's sense only. A bright part is no part (not a wrong one).
  int any = 0;
  EXPECT_EQ(found(**loc, r, false, 4, &any), 0);
  EXPECT_EQ(any, 0);
}

TEST_P(locate_polarity, IgnoreGlobalFindsBothSenses) {
  const auto r = scenes();
  DarkJob job = darkJob(r);
  job.taught.params["polarity"] = "ignore_global";
  auto loc = vgr::vision::makeLocator(GetParam(), job.templ, job.taught);
  ASSERT_TRUE(loc) << loc.error().message;
  EXPECT_EQ(found(**loc, r, true, 3), 3);
  EXPECT_EQ(found(**loc, r, false, 3), 3);
}

TEST_P(locate_polarity, BadWordsAreRefusedNamingTheParameter) {
  const auto r = scenes();
  DarkJob job = darkJob(r);
  for (const std::string word : {"ignore_local", "dark"}) {
    job.taught.params["polarity"] = word;
    auto loc = vgr::vision::makeLocator(GetParam(), job.templ, job.taught);
    ASSERT_FALSE(loc) << word;
    EXPECT_EQ(loc.error().message,
              GetParam() + ": parameter 'polarity': expected use or ignore_global, got '" + word + "'");
  }
}

INSTANTIATE_TEST_SUITE_P(segmentation, locate_polarity, ::testing::Values("moments", "hu"));

// `vgr teach --polarity` writes params.polarity; the job reads back and loads; a bad word in
// job.yaml is refused where the job loads, naming job.yaml, its line and the key.
TEST(locate_polarity_job, TeachOptionAndValidationOnLoad) {
  namespace fs = std::filesystem;
  const fs::path dir = fs::temp_directory_path() / ("vgr-polarity-" + std::to_string(::getpid()));
  fs::remove_all(dir);
  fs::create_directories(dir);
  const auto r = scenes();
  const DarkJob dark = darkJob(r);
  ASSERT_TRUE(cv::imwrite((dir / "dark.png").string(), dark.templ));

  vgr::tools::TeachOptions o;
  o.image = (dir / "dark.png").string();
  o.grasps = {std::to_string(dark.taught.grasp.u) + "," + std::to_string(dark.taught.grasp.v)};
  o.method = "hu";
  o.polarity = "ignore_global";
  o.autoRegions = false;
  o.out = (dir / "job").string();
  ASSERT_EQ(vgr::tools::runTeach(o), 0);
  auto job = vgr::config::loadJob(o.out);
  ASSERT_TRUE(job) << job.error().message;
  EXPECT_EQ(job->taught.params.at("polarity"), "ignore_global");
  EXPECT_TRUE(vgr::daemon::makeJobLocator(*job));

  // --polarity on a method without one, and twice: exit 2, nothing written.
  o.method = "sift";
  o.out = (dir / "job-sift").string();
  EXPECT_EQ(vgr::tools::runTeach(o), 2);
  EXPECT_FALSE(fs::exists(o.out));

  // A bad word written into job.yaml by hand.
  const fs::path yaml = dir / "job" / "job.yaml";
  std::ifstream in(yaml);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  in.close();
  const auto at = text.find("ignore_global");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, 13, "sideways");
  std::ofstream(yaml) << text;
  auto bad = vgr::config::loadJob((dir / "job").string());
  ASSERT_TRUE(bad) << bad.error().message;  // a method parameter: checked by the method
  auto loc = vgr::daemon::makeJobLocator(*bad);
  ASSERT_FALSE(loc);
  EXPECT_NE(loc.error().message.find("hu: parameter 'polarity': expected use or ignore_global, got 'sideways'"),
            std::string::npos)
      << loc.error().message;
  EXPECT_NE(loc.error().message.find("job.yaml:"), std::string::npos) << loc.error().message;
  EXPECT_NE(loc.error().message.find("key 'params.polarity'"), std::string::npos) << loc.error().message;
  fs::remove_all(dir);
}

}  // namespace
