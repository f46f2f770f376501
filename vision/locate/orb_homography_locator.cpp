#include "vision/locate/orb_homography_locator.hpp"

#include <string>
#include <utility>

#include <opencv2/calib3d.hpp>

#include "vision/locate/feature_match.hpp"
#include "vision/locate/params.hpp"

namespace vgr::vision {
namespace {

using detail::Features;
using detail::Match;
using detail::PartFit;

struct HomographyParams {
  double reprojThresholdPx = 3.0;  // [0.5, 20] inlier distance of the robust fit
  int maxIters = 2000;             // [100, 100000]
  double confidence = 0.995;       // [0.5, 0.9999]
};

// One robust homography over all candidates. `robust` is cv::RANSAC or cv::USAC_PROSAC;
// the candidates arrive sorted by descriptor distance, best first, which is PROSAC's
// "sorted by similarity" order (paper 001, section 4.2).
std::optional<PartFit> fitHomography(const std::vector<Match>& candidates, const Features& tmpl, const Features& img,
                                     int robust, const HomographyParams& p) {
  return robustHomography(candidates, tmpl, img, robust, p.reprojThresholdPx, p.maxIters, p.confidence);
}

class OrbHomographyLocator final : public Locator {
 public:
  OrbHomographyLocator(std::string name, const TaughtTemplate& taught, Features tmpl, detail::OrbParams orb,
                       detail::FeatureSearch search, detail::FitFn fit)
      : name_(std::move(name)), taught_(taught), tmpl_(std::move(tmpl)), hull_(detail::keypointHull(tmpl_)), orb_(orb),
        search_(std::move(search)), fit_(std::move(fit)) {}

  std::string_view method() const override { return name_; }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    return detail::locateFeatureParts(gray, taught_, tmpl_, hull_, orb_, search_, fit_);
  }

 private:
  std::string name_;
  TaughtTemplate taught_;
  Features tmpl_;
  std::vector<cv::Point2f> hull_;
  detail::OrbParams orb_;
  detail::FeatureSearch search_;
  detail::FitFn fit_;
};

Result<std::unique_ptr<Locator>> make(const std::string& name, int robust, const cv::Mat& templateGray,
                                      const TaughtTemplate& taught) {
  ParamReader r(name, taught);
  detail::OrbParams orb;
  detail::readOrbParams(r, orb);
  detail::FeatureSearch search;
  search.method = name;
  search.mu = r.number("mu", search.mu, 1, 20);
  search.minDFloor = r.number("min_distance_floor", search.minDFloor, 0, 64);
  search.minInliers = r.integer("min_inliers", search.minInliers, 4, 1000);
  search.maxScale = r.number("max_scale", search.maxScale, 1.01, 4);
  search.symmetric = r.flag("symmetric_matching", search.symmetric);
  HomographyParams hp;
  hp.reprojThresholdPx = r.number("reproj_threshold_px", hp.reprojThresholdPx, 0.5, 20);
  hp.maxIters = r.integer("max_iters", hp.maxIters, 100, 100000);
  hp.confidence = r.number("confidence", hp.confidence, 0.5, 0.9999);
  if (auto ok = r.finish(); !ok) return std::unexpected(ok.error());
  detail::applyScaleRange(taught, orb, search);

  detail::FitFn fit = [robust, hp](const std::vector<Match>& c, const Features& t, const Features& i) {
    return fitHomography(c, t, i, robust, hp);
  };
  Features tmpl = detail::detectOrb(templateGray, cv::Mat(), orb.templateFeatures, orb);
  auto ref = detail::selfMatchInliers(templateGray, tmpl, orb, search, fit);
  if (!ref) return std::unexpected(ref.error());
  search.fullScoreInliers = *ref;
  return std::make_unique<OrbHomographyLocator>(name, taught, std::move(tmpl), orb, std::move(search), std::move(fit));
}

}  // namespace

Result<std::unique_ptr<Locator>> makeOrbRansacLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  return make("orb-ransac", cv::RANSAC, templateGray, taught);
}

Result<std::unique_ptr<Locator>> makeOrbProsacLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  return make("orb-prosac", cv::USAC_PROSAC, templateGray, taught);
}

}  // namespace vgr::vision
