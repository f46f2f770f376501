#include "vision/locate/orb_adk_locator.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>
#include <string>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>

#include "vision/locate/feature_match.hpp"
#include "vision/locate/params.hpp"

namespace vgr::vision {
namespace {

using detail::Features;
using detail::Match;
using detail::PartFit;

struct AdkParams {
  double prosacThresholdPx = 3.0;  // [0.5, 20] PROSAC inlier distance (the pre-filter)
  double distanceBoundPx = 5.0;    // [0.5, 50] class bound on the distance difference (paper: 5 px)
  double angleBoundDeg = 3.0;      // [0.1, 30] class bound on the angle difference (paper: 3 degrees)
  int references = 10;             // [1, 50] most credible matches tried as the reference point
};

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

// The seeds of paper 001's k-means: points join a class while their distance difference is
// within the distance bound AND their angle difference within the angle bound of the
// class mean, and classes whose means are that close merge, "until the aggregation cannot
// continue". Returns a label per point and the class count. (The paper's sentence reads
// "less than 5 pixels or ... no more than 3 degrees"; with "or" single classes chain across
// the whole plane, so both bounds must hold.) `pts` are already divided by the bounds.
int seedClasses(const std::vector<cv::Point2f>& pts, std::vector<int>& labels) {
  struct Class {
    double sx = 0, sy = 0;
    int n = 0;
    cv::Point2d mean() const { return {sx / n, sy / n}; }
  };
  std::vector<Class> classes;
  labels.assign(pts.size(), -1);
  for (size_t k = 0; k < pts.size(); ++k) {
    int best = -1;
    for (size_t c = 0; c < classes.size() && best < 0; ++c) {
      const cv::Point2d m = classes[c].mean();
      if (std::abs(pts[k].x - m.x) < 1.0 && std::abs(pts[k].y - m.y) <= 1.0) best = static_cast<int>(c);
    }
    if (best < 0) {
      best = static_cast<int>(classes.size());
      classes.push_back({});
    }
    classes[static_cast<size_t>(best)].sx += pts[k].x;
    classes[static_cast<size_t>(best)].sy += pts[k].y;
    ++classes[static_cast<size_t>(best)].n;
    labels[k] = best;
  }
  // Merge classes whose means are within the bounds until none are.
  std::vector<int> parent(classes.size());
  for (size_t c = 0; c < parent.size(); ++c) parent[c] = static_cast<int>(c);
  for (bool merged = true; merged;) {
    merged = false;
    for (size_t a = 0; a < classes.size() && !merged; ++a) {
      if (classes[a].n == 0) continue;
      for (size_t b = a + 1; b < classes.size() && !merged; ++b) {
        if (classes[b].n == 0) continue;
        const cv::Point2d ma = classes[a].mean(), mb = classes[b].mean();
        if (std::abs(ma.x - mb.x) < 1.0 && std::abs(ma.y - mb.y) <= 1.0) {
          classes[a].sx += classes[b].sx;
          classes[a].sy += classes[b].sy;
          classes[a].n += classes[b].n;
          classes[b].n = 0;
          parent[b] = static_cast<int>(a);
          merged = true;
        }
      }
    }
  }
  // Compact labels 0..K-1.
  std::vector<int> compact(classes.size(), -1);
  int k = 0;
  for (size_t c = 0; c < classes.size(); ++c)
    if (classes[c].n > 0) compact[c] = k++;
  for (int& l : labels) {
    while (parent[static_cast<size_t>(l)] != l) l = parent[static_cast<size_t>(l)];
    l = compact[static_cast<size_t>(l)];
  }
  return k;
}

// ADK around one reference match (index `ref` into `set`): the matches of the dominant
// cluster of (distance difference, angle difference), the reference included.
std::vector<Match> adkCluster(const std::vector<Match>& set, size_t ref, const Features& tmpl, const Features& img,
                              const AdkParams& p) {
  const cv::Point2f t1 = tmpl.keypoints[static_cast<size_t>(set[ref].t)].pt;
  const cv::Point2f i1 = img.keypoints[static_cast<size_t>(set[ref].i)].pt;
  std::vector<cv::Point2f> feat;  // (D_k / distance bound, theta_k / angle bound)
  std::vector<size_t> which;
  std::vector<double> theta;
  double sx = 0, sy = 0;
  for (size_t k = 0; k < set.size(); ++k) {
    if (k == ref) continue;
    const cv::Point2f dt = tmpl.keypoints[static_cast<size_t>(set[k].t)].pt - t1;
    const cv::Point2f di = img.keypoints[static_cast<size_t>(set[k].i)].pt - i1;
    const double d1 = std::hypot(dt.x, dt.y), d2 = std::hypot(di.x, di.y);  // eq. (12)
    if (d1 < 1e-6 || d2 < 1e-6) continue;
    // eq. (14) with atan2 for the full circle (the paper's atan of the ratio loses the quadrant).
    const double a = std::atan2(dt.y, dt.x) - std::atan2(di.y, di.x);  // eq. (13)
    theta.push_back(a);
    sx += std::cos(a);
    sy += std::sin(a);
    feat.emplace_back(static_cast<float>((d1 - d2) / p.distanceBoundPx), 0.f);  // eq. (11)
    which.push_back(k);
  }
  if (feat.size() < 2) return {};
  // Angle differences relative to their circular mean, so that a cluster near +-180 degrees
  // is not cut in two by the wrap.
  const double centre = std::atan2(sy, sx);
  for (size_t k = 0; k < feat.size(); ++k)
    feat[k].y = static_cast<float>(std::remainder(theta[k] - centre, 2 * std::numbers::pi) * kRadToDeg / p.angleBoundDeg);

  std::vector<int> labels;
  const int classes = seedClasses(feat, labels);
  if (classes > 1 && classes < static_cast<int>(feat.size())) {
    // k-means from the seed classes (KMEANS_USE_INITIAL_LABELS: the first centres are the
    // seed classes' means, as the paper prescribes).
    cv::Mat data(static_cast<int>(feat.size()), 2, CV_32F, feat.data());
    cv::Mat lab(static_cast<int>(labels.size()), 1, CV_32S, labels.data());
    cv::kmeans(data, classes, lab, cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 1e-3), 1,
               cv::KMEANS_USE_INITIAL_LABELS);
  }
  std::vector<int> count(static_cast<size_t>(std::max(classes, 1)), 0);
  for (int l : labels) ++count[static_cast<size_t>(l)];
  const int dominant = static_cast<int>(std::max_element(count.begin(), count.end()) - count.begin());
  std::vector<Match> kept{set[ref]};
  for (size_t k = 0; k < labels.size(); ++k)
    if (labels[k] == dominant) kept.push_back(set[which[k]]);
  return kept;
}

std::optional<PartFit> fitAdk(const std::vector<Match>& candidates, const Features& tmpl, const Features& img,
                              const AdkParams& p, int minInliers) {
  // PROSAC over the candidates sorted by descriptor distance (they arrive sorted).
  auto prosac = robustHomography(candidates, tmpl, img, cv::USAC_PROSAC, p.prosacThresholdPx, 2000, 0.995);
  if (!prosac) return std::nullopt;
  // H of the paper: PROSAC's inliers, still most credible first.
  const std::vector<Match>& set = prosac->accepted;
  if (set.size() < 4) return std::nullopt;

  // The foremost match is the reference (m11, m21); should its cluster be too small (the
  // reference itself wrong), the next most credible ones are tried.
  std::vector<Match> best;
  for (size_t ref = 0; ref < set.size() && ref < static_cast<size_t>(p.references); ++ref) {
    auto kept = adkCluster(set, ref, tmpl, img, p);
    if (kept.size() > best.size()) best = std::move(kept);
    if (static_cast<int>(best.size()) >= minInliers && best.size() * 2 > set.size()) break;
  }
  std::vector<int> consumed;
  for (const Match& m : set) consumed.push_back(m.i);
  if (static_cast<int>(best.size()) < std::max(4, minInliers))
    return PartFit{cv::Matx33d::eye(), std::move(best), std::move(consumed), 0};
  std::vector<cv::Point2f> src, dst;
  for (const Match& m : best) {
    src.push_back(tmpl.keypoints[static_cast<size_t>(m.t)].pt);
    dst.push_back(img.keypoints[static_cast<size_t>(m.i)].pt);
  }
  // Least squares (then Levenberg-Marquardt) over every kept match: the "perspective
  // transformation matrix ... using these matching point pairs with higher precision".
  const cv::Mat H = cv::findHomography(src, dst, 0);
  if (H.empty()) return std::nullopt;
  return PartFit{cv::Matx33d(H), std::move(best), std::move(consumed), set.size()};
}

class OrbAdkLocator final : public Locator {
 public:
  OrbAdkLocator(const TaughtTemplate& taught, Features tmpl, detail::OrbParams orb, detail::FeatureSearch search,
                detail::FitFn fit)
      : taught_(taught), tmpl_(std::move(tmpl)), hull_(detail::keypointHull(tmpl_)), orb_(orb), search_(std::move(search)),
        fit_(std::move(fit)) {}

  std::string_view method() const override { return "orb-adk"; }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    return detail::locateFeatureParts(gray, taught_, tmpl_, hull_, orb_, search_, fit_);
  }

 private:
  TaughtTemplate taught_;
  Features tmpl_;
  std::vector<cv::Point2f> hull_;
  detail::OrbParams orb_;
  detail::FeatureSearch search_;
  detail::FitFn fit_;
};

}  // namespace

Result<std::unique_ptr<Locator>> makeOrbAdkLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  ParamReader r("orb-adk", taught);
  detail::OrbParams orb;
  detail::readOrbParams(r, orb);
  detail::FeatureSearch search;
  search.method = "orb-adk";
  search.mu = r.number("mu", search.mu, 1, 20);
  search.minDFloor = r.number("min_distance_floor", search.minDFloor, 0, 64);
  search.minInliers = r.integer("min_inliers", search.minInliers, 4, 1000);
  search.maxScale = r.number("max_scale", search.maxScale, 1.01, 4);
  AdkParams p;
  p.prosacThresholdPx = r.number("prosac_threshold_px", p.prosacThresholdPx, 0.5, 20);
  p.distanceBoundPx = r.number("distance_bound_px", p.distanceBoundPx, 0.5, 50);
  p.angleBoundDeg = r.number("angle_bound_deg", p.angleBoundDeg, 0.1, 30);
  p.references = r.integer("references", p.references, 1, 50);
  if (auto ok = r.finish(); !ok) return std::unexpected(ok.error());
  detail::applyScaleRange(taught, orb, search);

  const int minInliers = search.minInliers;
  detail::FitFn fit = [p, minInliers](const std::vector<Match>& c, const Features& t, const Features& i) {
    return fitAdk(c, t, i, p, minInliers);
  };
  Features tmpl = detail::detectOrb(templateGray, cv::Mat(), orb.templateFeatures, orb);
  auto ref = detail::selfMatchInliers(templateGray, tmpl, orb, search, fit);
  if (!ref) return std::unexpected(ref.error());
  search.fullScoreInliers = *ref;
  return std::make_unique<OrbAdkLocator>(taught, std::move(tmpl), orb, std::move(search), std::move(fit));
}

}  // namespace vgr::vision
