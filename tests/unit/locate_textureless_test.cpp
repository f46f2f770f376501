// Texture-less multi-height parts (issue 18, "methods that must not give up on ordinary
// parts"): the renderer's three-level part with plain faces (no grain, no print: sim
// PartSceneOptions::plainFaces), noise and clutter, placed anywhere at +-60 deg. Paper 000's
// contour-weighted method takes its initial pose from ORB (section III.A), which finds almost
// nothing there; with the gradient-direction initial pose it must reach paper 000's success
// (grasp point <= 4 px and angle <= 0.5 deg) on >= 95 % of the parts, with the operator's
// regions (the dataset template's, height factor 1 at the grasp height, 0.1 elsewhere), and
// be ahead of `hu` and `orb-ransac` on the same images. The full-size figures (200 images)
// are in docs/localization-methods.md.
#include <cmath>
#include <cstdio>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "sim/part_scene.hpp"
#include "vision/locate/locator.hpp"

namespace {

using vgr::sim::PartModel;
using vgr::sim::PartSceneOptions;
using vgr::sim::PartSceneRenderer;

constexpr int kImages = 20;

PartSceneRenderer plainScenes() {
  PartSceneOptions o;
  o.plainFaces = true;
  o.noiseSigma = 5;
  o.clutter = 4;
  o.angleRangeDeg = 60;
  o.seed = 31;
  return PartSceneRenderer(PartModel::multi(3), o);
}

struct Job {
  cv::Mat templ;
  vgr::vision::TaughtTemplate taught;
};

Job taughtJob(const PartSceneRenderer& r) {
  Job j;
  const auto t = r.renderTemplate(j.templ);
  j.taught.grasp = {t.graspU, t.graspV};
  j.taught.minScore = 0.3;
  for (const auto& reg : t.regions) {
    vgr::vision::TemplateRegion tr;
    tr.polygon = reg.polygon;
    tr.heightMm = reg.heightMm;
    tr.heightFactor = std::abs(reg.heightMm - r.part().graspHeightMm) < 1e-6 ? 1.0 : 0.1;
    j.taught.regions.push_back(tr);
  }
  return j;
}

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

// Paper 000's success rate of `method` over the first kImages scenes: the part found with its
// grasp point within 4 px and its angle within 0.5 deg of the renderer's truth.
double successRate(const std::string& method, const PartSceneRenderer& r, const Job& job) {
  auto loc = vgr::vision::makeLocator(method, job.templ, job.taught);
  if (!loc) {
    ADD_FAILURE() << method << ": " << loc.error().message;
    return 0;
  }
  int ok = 0;
  cv::Mat img;
  for (int i = 0; i < kImages; ++i) {
    const auto scene = r.sample(static_cast<std::uint64_t>(i));
    r.render(scene, img);
    auto out = (*loc)->locate(img);
    if (!out) {
      ADD_FAILURE() << method << ": " << out.error().message;
      continue;
    }
    const auto& t = scene.parts.at(0);
    for (const auto& d : out->parts)
      if (std::hypot(d.u - t.uPx, d.v - t.vPx) <= 4.0 && angleDiff(d.angleDeg, t.angleDeg) <= 0.5) {
        ++ok;
        break;
      }
  }
  return static_cast<double>(ok) / kImages;
}

// Failed before: the job did not load ("only N ORB features in the template ... too little
// texture"), and with ORB features forced it found no part.
TEST(locate_textureless, ContourWeightedReachesPaper000SuccessAheadOfHuAndOrbRansac) {
  const auto r = plainScenes();
  const Job job = taughtJob(r);
  const double cw = successRate("contour-weighted", r, job);
  const double hu = successRate("hu", r, job);
  const double orb = [&] {
    // orb-ransac refuses a template it cannot find in itself: that is 0 % too.
    auto loc = vgr::vision::makeLocator("orb-ransac", job.templ, job.taught);
    return loc ? successRate("orb-ransac", r, job) : 0.0;
  }();
  std::printf("texture-less multi-height, %d images: contour-weighted %.0f %%, hu %.0f %%, orb-ransac %.0f %%\n", kImages,
              100 * cw, 100 * hu, 100 * orb);
  EXPECT_GE(cw, 0.95);
  EXPECT_GT(cw, hu);
  EXPECT_GT(cw, orb);
}

// Paper 000 as written (initial_pose: orb) still refuses a template without texture, naming
// the cause; the default (auto) and `gradient` take it.
TEST(locate_textureless, InitialPoseParameter) {
  const auto r = plainScenes();
  Job job = taughtJob(r);
  job.taught.params["initial_pose"] = "orb";
  job.taught.params["min_matches"] = "1000";  // no template has that many consistent features
  auto orb = vgr::vision::makeLocator("contour-weighted", job.templ, job.taught);
  ASSERT_FALSE(orb);
  EXPECT_NE(orb.error().message.find("too little texture"), std::string::npos) << orb.error().message;
  job.taught.params["initial_pose"] = "gradient";
  EXPECT_TRUE(vgr::vision::makeLocator("contour-weighted", job.templ, job.taught));
  job.taught.params["initial_pose"] = "keypoints";
  auto bad = vgr::vision::makeLocator("contour-weighted", job.templ, job.taught);
  ASSERT_FALSE(bad);
  EXPECT_NE(bad.error().message.find("parameter 'initial_pose': expected auto, orb or gradient, got 'keypoints'"),
            std::string::npos)
      << bad.error().message;
}

}  // namespace
