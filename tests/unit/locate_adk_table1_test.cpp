// Paper 001, Table 1 (ADK 99.1 % true positives, PROSAC 85.3 %, RANSAC 83.5 %) on a hard
// rendered set: multi-height parts (3 levels, grasped on the 35 mm boss), +-60 degrees,
// noise sigma 5, six same-texture decoys per image (`vgr sim render --decoys 6`,
// docs/datasets.md), 1280 x 1024, one part per image; rendered in memory (no files) to keep
// the test short. Both rates are scored as `vgr eval` scores them (tools/vgr/eval_report.cpp):
//  - match TP: the best part's accepted matches whose template point, on any of the part's
//    levels, carried by the truth pose into the image, lands within 5 px of the matched point;
//  - grasp TP (paper 001, section 5.1, the one definition of a true positive the paper gives,
//    which we read as Table 1's): grasp error < 3 mm and < 2 degrees; a missed part is not
//    a true positive.
//
// What holds and is asserted (docs/localization-methods.md, "Paper 001's Table 1"):
//  - orb-adk's match TP >= 98 % (our bar; paper 001, section 4.2: ADK's "false matching
//    rate ... below 1 per cent"). It is NOT asserted that orb-adk beats the baselines on this
//    rate: their inliers are > 99.8 % true as well (a 3 px robust fit leaves no room for
//    Table 1's 15-point gap; only looser baseline thresholds open a gap of 2-6 points), and
//    which of the three is highest changes from set to set.
//  - On paper 001's own true positive (grasp TP) orb-adk is ahead of orb-prosac and
//    orb-ransac. None of the three comes near 98 % on this set: one homography cannot carry
//    a grasp point on a 35 mm boss across the image (the projection difference of paper 000).
#include <cmath>
#include <cstdio>
#include <memory>
#include <string>
#include <vector>

#include <gtest/gtest.h>
#include <opencv2/core.hpp>

#include "sim/part_scene.hpp"
#include "vision/locate/locator.hpp"

namespace {

using vgr::sim::PartModel;
using vgr::sim::PartSceneOptions;
using vgr::sim::PartSceneRenderer;

constexpr double kDegToRad = M_PI / 180.0;

struct Tally {
  long matches = 0, trueMatches = 0;
  int parts = 0, graspTp = 0;
  double matchRate() const { return matches ? double(trueMatches) / matches : 0; }
  double graspRate() const { return parts ? double(graspTp) / parts : 0; }
};

TEST(locate_adk_table1, AdkAheadOfProsacAndRansacOnMultiHeightPartsWithDecoys) {
  PartSceneOptions o;  // 1280 x 1024, camera 500 mm above the belt, f = 1000 px
  o.angleRangeDeg = 60;
  o.noiseSigma = 5;
  o.decoys = 6;
  o.seed = 11;
  const PartSceneRenderer r(PartModel::multi(3), o);
  cv::Mat templ;
  const vgr::sim::PartTemplate t = r.renderTemplate(templ);
  vgr::vision::TaughtTemplate taught;  // as `vgr teach --min-score 0.3` writes it
  taught.grasp = {t.graspU, t.graspV};
  taught.minScore = 0.3;

  const std::vector<std::string> methods{"orb-adk", "orb-prosac", "orb-ransac"};
  std::vector<std::unique_ptr<vgr::vision::Locator>> locators;
  for (const auto& m : methods) {
    auto loc = vgr::vision::makeLocator(m, templ, taught);
    ASSERT_TRUE(loc.has_value()) << m << ": " << loc.error().message;
    locators.push_back(std::move(*loc));
  }
  const double mmPerPx = (o.cameraHeightMm - r.part().graspHeightMm) / r.focalPx();

  std::vector<Tally> tally(methods.size());
  cv::Mat img;
  constexpr int kImages = 150;  // ~18 s CPU
  for (int i = 0; i < kImages; ++i) {
    const auto scene = r.sample(static_cast<std::uint64_t>(i));
    ASSERT_EQ(scene.parts.size(), 1u);
    const auto& truth = scene.parts.front();
    r.render(scene, img);
    const double c = std::cos(truth.rzDeg * kDegToRad), s = std::sin(truth.rzDeg * kDegToRad);
    for (std::size_t k = 0; k < methods.size(); ++k) {
      auto out = locators[k]->locate(img);
      ASSERT_TRUE(out.has_value()) << out.error().message;
      ++tally[k].parts;
      if (out->parts.empty()) continue;
      const auto& d = out->parts.front();
      const double pe = std::hypot(d.u - truth.uPx, d.v - truth.vPx);
      const double ae = std::abs(std::remainder(d.angleDeg - truth.angleDeg, 360.0));
      if (pe * mmPerPx < 3 && ae < 2) ++tally[k].graspTp;
      for (const auto& m : out->matches) {
        ++tally[k].matches;
        for (const auto& region : t.regions) {
          const auto q = r.camera().pixelToPlane({m.templatePx.u + t.offsetX, m.templatePx.v + t.offsetY}, region.heightMm);
          if (!q) continue;
          const auto px = r.camera().project({truth.xMm + c * q->x - s * q->y, truth.yMm + s * q->x + c * q->y, region.heightMm});
          if (px && std::hypot(px->u - m.imagePx.u, px->v - m.imagePx.v) <= 5.0) {
            ++tally[k].trueMatches;
            break;
          }
        }
      }
    }
  }
  for (std::size_t k = 0; k < methods.size(); ++k)
    std::printf("%s: match TP %.4f (%ld matches), grasp TP %.3f\n", methods[k].c_str(), tally[k].matchRate(),
                tally[k].matches, tally[k].graspRate());
  const Tally &adk = tally[0], &prosac = tally[1], &ransac = tally[2];

  // Measured on this set (the first 150 images of seed 11): match TP orb-adk 0.9998,
  // orb-prosac 0.9996, orb-ransac 1.0000; grasp TP 0.313, 0.213, 0.067 (all 200 images:
  // 0.310, 0.205, 0.095). The 200 images through `vgr eval` (other FLANN LSH hash tables:
  // they are shuffled with cv::theRNG(), whose state depends on what ran before) gave grasp
  // TP 0.265, 0.21, 0.07; four 200-image sets (seeds 7 and 11, with and without decoys) gave
  // orb-adk ahead of orb-prosac by 5.5-10.5 points and of orb-ransac by 16.5-22.5 points.
  // The bars below leave about half of the smallest gap as room.
  EXPECT_GT(adk.matches, 2000);
  EXPECT_GE(adk.matchRate(), 0.98);
  EXPECT_GT(adk.graspRate(), prosac.graspRate() + 0.03);
  EXPECT_GT(adk.graspRate(), ransac.graspRate() + 0.10);
}

}  // namespace
