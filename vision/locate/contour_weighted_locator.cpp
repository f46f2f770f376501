#include "vision/locate/contour_weighted_locator.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/core.h>
#include <numbers>
#include <optional>
#include <string>
#include <utility>

#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/imgproc.hpp>

#include "core/angles.hpp"
#include "vision/locate/feature_match.hpp"
#include "vision/locate/params.hpp"
#include "vision/locate/shape_matcher.hpp"

namespace vgr::vision {
namespace {

using detail::Features;

constexpr double kDegToRad = std::numbers::pi / 180.0;

struct CwParams {
  // Segmentation (section III.A, Fig. 3).
  int threshold = 0;            // gray level [0, 255]; 0 = Otsu
  double minAreaRatio = 0.5;    // [0.05, 1] candidate blob area / the template part's area
  double maxAreaRatio = 1.6;    // [1, 10]
  // Initial match (section III.A).
  detail::OrbParams orb;
  double gridCellPx = 40;       // [8, 400] cell of the unilateral grid over the template
  int gridMinSupport = 2;       // [0, 50] neighbours that must move consistently with a match
  double tauPx = 3;             // [0.5, 20] eq. (2) distance error threshold (paper: 3)
  int minMatches = 8;           // [3, 1000] matches left for theta_init, d_init
  // Contour model (section III.B).
  double edgeLow = 40, edgeHigh = 100;  // Canny thresholds on the template [1, 1000]
  double minGradient = 20;      // [1, 1000] gradient magnitude that counts as an edge in eq. (5)
  int maxPoints = 1500;         // [50, 20000] contour points kept (evenly thinned)
  int autoRegions = 3;          // [1, 16] regions split by position when the job gives none
  double rDeg = 5;              // [0.1, 45] eq. (6) rotation radius r (paper: 5)
  double lFraction = 0.2;       // [0.01, 1] eq. (6) translation radius l / circumscribed radius (paper: 0.2)
  bool perHeightShift = true;   // a translation per height group (see searchGrid); false = eq. (6) as written
  // Where theta_init, d_init come from (section III.A gives ORB; parts without texture have
  // too few keypoints for it): "orb" = paper 000's ORB + grid + eq. (2) only; "gradient" = the
  // shape matcher's gradient-direction search (shape_matcher.hpp) only; "auto" = ORB when the
  // template has at least minTemplateKeypoints ORB keypoints and the candidate gives enough
  // consistent matches, the gradient search otherwise.
  enum class Init { Auto, Orb, Gradient } init = Init::Auto;
  int minTemplateKeypoints = 100;  // [3, 20000] auto: fewer template keypoints = texture-less, no ORB
  int autoOrbMatches = 24;         // [3, 1000] auto: fewer matches passing eq. (2) = too little texture
                                   // (measured: textured 35-68 per part, plain faces 8-17)
  double initMinScore = 0.3;       // [0.1, 1] the gradient search's min_score (a rigid fit of all heights:
                                   // 0.66 measured for a part in an image corner, the boss 35 px off)
};

// One contour point of the template, relative to the grasp point, with its unit gradient
// and its share of eq. (5)'s weight: w_i / n_i of its region i (the shares sum to 1).
struct ContourPoint {
  cv::Point2f p;   // template px minus the grasp point
  cv::Point2f g;   // unit gradient (T_x, T_y) / |T|
  float weight;
};

// Gradient of an image, each vector divided by max(|B|, minGradient): eq. (5) with the
// magnitudes dividing instead of multiplying, so S is a weighted mean cosine in [-1, 1]
// (see docs/localization-methods.md) and weak noise gradients count little.
cv::Mat normalisedGradient(const cv::Mat& gray, double blurSigma, double minGradient) {
  cv::Mat blurred, gx, gy;
  cv::GaussianBlur(gray, blurred, cv::Size(), blurSigma);
  cv::Sobel(blurred, gx, CV_32F, 1, 0, 3);
  cv::Sobel(blurred, gy, CV_32F, 0, 1, 3);
  cv::Mat mag;
  cv::magnitude(gx, gy, mag);
  cv::max(mag, minGradient, mag);
  cv::divide(gx, mag, gx);
  cv::divide(gy, mag, gy);
  cv::Mat out;
  cv::merge(std::vector<cv::Mat>{gx, gy}, out);
  return out;  // CV_32FC2
}

inline cv::Vec2f sampleNearest(const cv::Mat& g, float x, float y) {
  const int ix = cvRound(x), iy = cvRound(y);
  if (ix < 0 || iy < 0 || ix >= g.cols || iy >= g.rows) return {0, 0};
  return g.at<cv::Vec2f>(iy, ix);
}

inline cv::Vec2f sampleBilinear(const cv::Mat& g, float x, float y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  if (x0 < 0 || y0 < 0 || x0 + 1 >= g.cols || y0 + 1 >= g.rows) return {0, 0};
  const float fx = x - static_cast<float>(x0), fy = y - static_cast<float>(y0);
  const cv::Vec2f* r0 = g.ptr<cv::Vec2f>(y0) + x0;
  const cv::Vec2f* r1 = g.ptr<cv::Vec2f>(y0 + 1) + x0;
  return (r0[0] * (1 - fx) + r0[1] * fx) * (1 - fy) + (r1[0] * (1 - fx) + r1[1] * fx) * fy;
}

// Paper 000, eq. (5) at one pose, summed over `pts` (not yet divided by their weight): the template turned counter-clockwise (as displayed) by
// theta about the grasp point, the grasp point at (u, v) of the gradient image.
template <bool kBilinear>
double similarity(const cv::Mat& grad, const std::vector<ContourPoint>& pts, double u, double v, double thetaDeg) {
  const float c = static_cast<float>(std::cos(thetaDeg * kDegToRad)), s = static_cast<float>(std::sin(thetaDeg * kDegToRad));
  const float fu = static_cast<float>(u), fv = static_cast<float>(v);
  double sum = 0;
  for (const ContourPoint& k : pts) {
    // (x, y) -> (x cos + y sin, -x sin + y cos): counter-clockwise as displayed, y down.
    const float x = fu + k.p.x * c + k.p.y * s, y = fv - k.p.x * s + k.p.y * c;
    const float tx = k.g.x * c + k.g.y * s, ty = -k.g.x * s + k.g.y * c;
    const cv::Vec2f b = kBilinear ? sampleBilinear(grad, x, y) : sampleNearest(grad, x, y);
    sum += k.weight * (tx * b[0] + ty * b[1]);
  }
  return sum;  // the caller divides by the points' total weight
}

// A pose of eq. (6): the rotation theta and, per height group, where that group puts the
// grasp point (all groups share theta; see searchGrid).
struct Pose {
  double theta = 0;
  std::vector<cv::Point2d> d;  // per group, image px
  double score = -2;
};

// Exhaustive search of eq. (6) on a grid around `centre` (angle +- angRange, every group's
// translation +- posRange), clipped to the eq. (6) box theta_init +- r, d_init +- l.
// Height groups: paper 000 moves all contours by one (theta, d). The projection difference
// moves the contours of each height by its own translation (a layer at height h is imaged
// with scale Hc / (Hc - h) about the principal point in the template and in the live image
// alike, so between the two it only turns and shifts), so with perHeightShift each group of
// regions of one height gets its own d for the same theta: S(theta) = sum over groups of
// max over d_g of the group's part of eq. (5). With one group this is eq. (6) as written.
template <bool kBilinear>
Pose searchGrid(const cv::Mat& grad, const std::vector<std::vector<ContourPoint>>& groups, double totalWeight,
                const Pose& centre, double angRange, double angStep, double posRange, double posStep, double thetaInit,
                cv::Point2d dInit, double r, double l) {
  Pose best;
  const int na = static_cast<int>(std::round(angRange / angStep)), np = static_cast<int>(std::round(posRange / posStep));
  Pose cur;
  cur.d.resize(groups.size());
  for (int ia = -na; ia <= na; ++ia) {
    cur.theta = centre.theta + ia * angStep;
    if (std::abs(cur.theta - thetaInit) > r) continue;
    double total = 0;
    for (size_t g = 0; g < groups.size(); ++g) {
      double bestG = -1e300;
      for (int iy = -np; iy <= np; ++iy) {
        const double v = centre.d[g].y + iy * posStep;
        if (std::abs(v - dInit.y) > l) continue;
        for (int ix = -np; ix <= np; ++ix) {
          const double u = centre.d[g].x + ix * posStep;
          if (std::abs(u - dInit.x) > l) continue;
          const double sg = similarity<kBilinear>(grad, groups[g], u, v, cur.theta);
          if (sg > bestG) {
            bestG = sg;
            cur.d[g] = {u, v};
          }
        }
      }
      total += bestG;
    }
    cur.score = total / totalWeight;
    if (cur.score > best.score) best = cur;
  }
  return best;
}

double totalWeight(const std::vector<std::vector<ContourPoint>>& groups) {
  double w = 0;
  for (const auto& g : groups)
    for (const auto& k : g) w += k.weight;
  return w;
}

class ContourWeightedLocator final : public Locator {
 public:
  // groups: the contour points by height group; graspGroup: the group whose translation
  // is the grasp point's.
  // useOrb: the ORB initial pose is tried first; gradient: the texture-free initial pose
  // (may be null when useOrb).
  ContourWeightedLocator(const TaughtTemplate& taught, CwParams p, Features tmpl, bool useOrb,
                         std::unique_ptr<Locator> gradient, std::vector<std::vector<ContourPoint>> groups,
                         size_t graspGroup, double partArea, double circumRadius)
      : taught_(taught), p_(std::move(p)), tmpl_(std::move(tmpl)), useOrb_(useOrb), gradient_(std::move(gradient)),
        groups_(std::move(groups)), graspGroup_(graspGroup), partArea_(partArea), l_(p_.lFraction * circumRadius) {
    // A thinned copy (about 400 points) for the coarse search stage.
    size_t n = 0;
    for (const auto& g : groups_) n += g.size();
    const size_t stride = std::max<size_t>(1, n / 400);
    for (const auto& g : groups_) {
      coarse_.emplace_back();
      for (size_t k = 0; k < g.size(); k += stride) coarse_.back().push_back(g[k]);
    }
    weight_ = totalWeight(groups_);
    coarseWeight_ = totalWeight(coarse_);
  }

  std::string_view method() const override { return "contour-weighted"; }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    if (gray.empty() || gray.type() != CV_8UC1)
      return fail(Status::BadArgument, "contour-weighted: expected a non-empty 8-bit gray image");
    const cv::Rect roi = detail::searchRect(gray, taught_);
    LocateOutput out;
    if (roi.empty()) return out;
    const cv::Mat img = gray(roi);

    // Binary segmentation into candidates (section III.A, Fig. 3): outer contours of the
    // foreground whose area is near the template part's.
    cv::Mat binary;
    if (p_.threshold > 0)
      cv::threshold(img, binary, p_.threshold, 255, cv::THRESH_BINARY);
    else
      cv::threshold(img, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
    std::vector<std::vector<cv::Point>> contours;
    cv::findContours(binary, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_SIMPLE);

    struct Found {
      Detection d;
      std::vector<MatchPair> pairs;
      int candidates = 0;
    };
    std::vector<Found> found;
    bool gradientsReady = false;
    initials_.reset();
    for (size_t c = 0; c < contours.size(); ++c) {
      const double area = cv::contourArea(contours[c]);
      if (area < p_.minAreaRatio * partArea_ || area > p_.maxAreaRatio * partArea_) continue;
      if (!gradientsReady) {  // only for images that have a candidate at all
        coarseGrad_ = normalisedGradient(img, 2.0, p_.minGradient);
        fineGrad_ = normalisedGradient(img, 1.0, p_.minGradient);
        gradientsReady = true;
      }
      Found f;
      bool ok = false;
      if (useOrb_) {
        // auto: an ORB pose resting on few matches (texture-less faces: outline corners that
        // match several places) is not trusted when the gradient search can give one.
        const int needed = p_.init == CwParams::Init::Auto && gradient_ ? std::max(p_.minMatches, p_.autoOrbMatches) : p_.minMatches;
        auto init = orbInitialPose(img, contours, static_cast<int>(c), f.pairs, f.candidates);
        if (init && static_cast<int>(f.pairs.size()) >= needed) ok = refine(*init, contours[c], f.d);
      }
      if (!ok && gradient_) {
        // No texture to match (or the ORB pose did not pass eq. 7): the gradient search's pose.
        f.pairs.clear();
        f.candidates = 0;
        auto init = gradientInitialPose(img, contours[c]);
        if (!init) return std::unexpected(init.error());
        ok = init->has_value() && refine(**init, contours[c], f.d);
      }
      if (!ok) continue;
      f.d.u += roi.x;
      f.d.v += roi.y;
      for (MatchPair& m : f.pairs) {
        m.imagePx.u += roi.x;
        m.imagePx.v += roi.y;
      }
      found.push_back(std::move(f));
    }
    std::stable_sort(found.begin(), found.end(), [](const Found& a, const Found& b) { return a.d.score > b.d.score; });
    if (static_cast<int>(found.size()) > taught_.maxParts) found.resize(static_cast<size_t>(taught_.maxParts));
    for (const Found& f : found) out.parts.push_back(f.d);
    if (!found.empty()) {
      out.matches = found.front().pairs;
      out.candidateMatches = found.front().candidates;
    }
    return out;
  }

 private:
  // theta_init (deg, CCW as displayed) and d_init (the grasp point, ROI px) of section III.A.
  struct Initial {
    double thetaDeg = 0;
    cv::Point2d d;
  };

  // The initial pose from the gradient-direction search (the shape matcher, run once per image
  // on the ROI; its regions let the grasp point follow its own height): the best of its parts
  // whose grasp point lies on the candidate; nullopt when none does. An Error only when the
  // search itself failed.
  Result<std::optional<Initial>> gradientInitialPose(const cv::Mat& img, const std::vector<cv::Point>& contour) {
    if (!initials_) {
      auto out = gradient_->locate(img);
      if (!out) return std::unexpected(out.error());
      initials_ = std::move(out->parts);
    }
    for (const Detection& g : *initials_)  // best score first
      if (cv::pointPolygonTest(contour, cv::Point2f(static_cast<float>(g.u), static_cast<float>(g.v)), true) >= -2.0)
        return std::optional<Initial>(Initial{g.angleDeg, {g.u, g.v}});
    return std::optional<Initial>{};
  }

  // theta_init, d_init from ORB matches in one candidate (section III.A); nullopt when there
  // are too few consistent matches.
  std::optional<Initial> orbInitialPose(const cv::Mat& img, const std::vector<std::vector<cv::Point>>& contours, int which,
                                        std::vector<MatchPair>& pairs, int& candidates) {
    const int margin = 12;
    const cv::Rect box = (cv::boundingRect(contours[static_cast<size_t>(which)]) + cv::Size(2 * margin, 2 * margin) -
                          cv::Point(margin, margin)) & cv::Rect(0, 0, img.cols, img.rows);
    cv::Mat mask(box.size(), CV_8U, cv::Scalar(0));
    cv::drawContours(mask, contours, which, cv::Scalar(255), cv::FILLED, cv::LINE_8, cv::noArray(), 0, -box.tl());
    cv::dilate(mask, mask, cv::getStructuringElement(cv::MORPH_ELLIPSE, {2 * margin - 1, 2 * margin - 1}));
    const Features cand = detail::detectOrb(img(box), mask, p_.orb.imageFeatures, p_.orb);
    if (cand.keypoints.size() < static_cast<size_t>(p_.minMatches) || tmpl_.keypoints.size() < 3) return std::nullopt;

    // Hypothetical matches by brute force (Hamming), template -> candidate.
    cv::BFMatcher bf(cv::NORM_HAMMING, true);
    std::vector<cv::DMatch> raw;
    bf.match(tmpl_.descriptors, cand.descriptors, raw);
    candidates = static_cast<int>(raw.size());

    // Unilateral grid over the template: a match is kept when at least gridMinSupport of
    // the matches in its own and the 8 neighbouring cells keep their distance to it (the
    // local clustering constraint). Hand-written: OpenCV's GMS (xfeatures2d) grids both
    // images and needs far more matches than a part crop gives.
    const double cell = p_.gridCellPx;
    auto cellOf = [cell](cv::Point2f q) { return cv::Point(cvFloor(q.x / cell), cvFloor(q.y / cell)); };
    std::vector<cv::Point2f> src, dst;
    for (size_t a = 0; a < raw.size(); ++a) {
      const cv::Point2f pa = tmpl_.keypoints[static_cast<size_t>(raw[a].queryIdx)].pt;
      const cv::Point2f qa = cand.keypoints[static_cast<size_t>(raw[a].trainIdx)].pt;
      const cv::Point ca = cellOf(pa);
      int support = 0;
      for (size_t b = 0; b < raw.size() && support < p_.gridMinSupport; ++b) {
        if (a == b) continue;
        const cv::Point2f pb = tmpl_.keypoints[static_cast<size_t>(raw[b].queryIdx)].pt;
        const cv::Point cb = cellOf(pb);
        if (std::abs(cb.x - ca.x) > 1 || std::abs(cb.y - ca.y) > 1) continue;
        const cv::Point2f qb = cand.keypoints[static_cast<size_t>(raw[b].trainIdx)].pt;
        const double dp = cv::norm(pa - pb), dq = cv::norm(qa - qb);
        if (std::abs(dp - dq) < p_.tauPx + 0.1 * dp) ++support;
      }
      if (support < p_.gridMinSupport) continue;
      src.push_back(pa);
      dst.push_back(qa);
    }
    if (static_cast<int>(src.size()) < p_.minMatches) return std::nullopt;

    // Local linear (similarity) transformation re-screen with eq. (2): ||q_i - H(p_i)|| < tau.
    std::vector<unsigned char> inl;
    cv::Mat A = cv::estimateAffinePartial2D(src, dst, inl, cv::RANSAC, p_.tauPx, 2000, 0.995, 10);
    if (A.empty()) return std::nullopt;
    std::vector<cv::Point2f> s2, d2;
    for (size_t k = 0; k < src.size(); ++k) {
      const cv::Point2f h(static_cast<float>(A.at<double>(0, 0) * src[k].x + A.at<double>(0, 1) * src[k].y + A.at<double>(0, 2)),
                          static_cast<float>(A.at<double>(1, 0) * src[k].x + A.at<double>(1, 1) * src[k].y + A.at<double>(1, 2)));
      if (cv::norm(dst[k] - h) < p_.tauPx) {  // eq. (2)
        s2.push_back(src[k]);
        d2.push_back(dst[k]);
      }
    }
    if (static_cast<int>(s2.size()) < p_.minMatches) return std::nullopt;
    // [[a, -b, tx], [b, a, ty]]: the turn counter-clockwise as displayed is -atan2(b, a).
    const double a = A.at<double>(0, 0), b = A.at<double>(1, 0);
    const double scale = std::hypot(a, b);
    if (scale < 0.8 || scale > 1.25) return std::nullopt;
    Initial init;
    init.thetaDeg = -std::atan2(b, a) / kDegToRad;
    init.d = cv::Point2d(box.x + a * taught_.grasp.u - b * taught_.grasp.v + A.at<double>(0, 2),  // d_init: the grasp
                         box.y + b * taught_.grasp.u + a * taught_.grasp.v + A.at<double>(1, 2));  // point through it
    for (size_t k = 0; k < s2.size(); ++k)
      pairs.push_back({{s2[k].x, s2[k].y}, {d2[k].x + box.x, d2[k].y + box.y}});
    return init;
  }

  // Section III.B from an initial pose: eq. (6)'s search of eq. (5) inside theta_init +- r,
  // d_init +- l, and eq. (7)'s test. False: S_max <= sigma, or outside the job's angle range.
  bool refine(const Initial& initial, const std::vector<cv::Point>& contour, Detection& d) {
    const double thetaInit = initial.thetaDeg;
    const cv::Point2d dInit = initial.d;

    // Eq. (6): S_max over theta_init +- r, d_init +- l, coarse to fine (a full-resolution
    // exhaustive grid would cost ~1e9 samples per part).
    const double r = p_.rDeg, l = l_;
    Pose init;
    init.theta = thetaInit;
    init.d.assign(groups_.size(), dInit);
    double thetaCentre = thetaInit;
    Pose best = searchGrid<false>(coarseGrad_, coarse_, coarseWeight_, init, r, 1.0, l, 2.0, thetaCentre, dInit, r, l);
    // theta_init comes from a similarity over a few matches; when they sit on one small
    // feature (a boss) it can be off by more than r. A maximum on the edge of the angle
    // range is then not S_max: the range moves there, at most twice.
    for (int moves = 0; moves < 2 && std::abs(best.theta - thetaCentre) > r - 1.0; ++moves) {
      thetaCentre = best.theta;
      init.theta = thetaCentre;
      best = searchGrid<false>(coarseGrad_, coarse_, coarseWeight_, init, r, 1.0, l, 2.0, thetaCentre, dInit, r, l);
    }
    best = searchGrid<true>(fineGrad_, groups_, weight_, best, 1.5, 0.25, 2.0, 0.5, thetaCentre, dInit, r, l);
    best = searchGrid<true>(fineGrad_, groups_, weight_, best, 0.3, 0.05, 0.5, 0.1, thetaCentre, dInit, r, l);
    const double score = std::clamp(best.score, 0.0, 1.0);
    if (!(score > taught_.minScore)) return false;  // eq. (7): S_max > sigma
    d.u = best.d[graspGroup_].x;
    d.v = best.d[graspGroup_].y;
    d.angleDeg = normaliseDeg(best.theta);
    d.score = score;
    d.areaPx = cv::contourArea(contour);
    if (d.angleDeg < taught_.angleMinDeg || d.angleDeg > taught_.angleMaxDeg) return false;
    return true;
  }

  TaughtTemplate taught_;
  CwParams p_;
  Features tmpl_;
  bool useOrb_;
  std::unique_ptr<Locator> gradient_;
  std::optional<std::vector<Detection>> initials_;  // per image: the gradient search's parts, computed when first needed
  std::vector<std::vector<ContourPoint>> groups_, coarse_;
  size_t graspGroup_;
  double weight_ = 1, coarseWeight_ = 1;
  double partArea_;
  double l_;
  cv::Mat coarseGrad_, fineGrad_;  // scratch, per image
};

// The template part: the largest outer contour of the segmented template.
std::vector<cv::Point> templatePart(const cv::Mat& templ, int threshold) {
  cv::Mat binary;
  if (threshold > 0)
    cv::threshold(templ, binary, threshold, 255, cv::THRESH_BINARY);
  else
    cv::threshold(templ, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  std::vector<std::vector<cv::Point>> contours;
  cv::findContours(binary, contours, cv::RETR_EXTERNAL, cv::CHAIN_APPROX_NONE);
  std::vector<cv::Point> best;
  double bestArea = 0;
  for (auto& c : contours)
    if (const double a = cv::contourArea(c); a > bestArea) {
      bestArea = a;
      best = c;
    }
  return best;
}

}  // namespace

Result<std::unique_ptr<Locator>> makeContourWeightedLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  const std::string name = "contour-weighted";
  ParamReader r(name, taught);
  CwParams p;
  p.orb.imageFeatures = 2000;  // per candidate crop
  p.threshold = r.integer("threshold", p.threshold, 0, 255);
  p.minAreaRatio = r.number("min_area_ratio", p.minAreaRatio, 0.05, 1);
  p.maxAreaRatio = r.number("max_area_ratio", p.maxAreaRatio, 1, 10);
  detail::readOrbParams(r, p.orb);
  p.gridCellPx = r.number("grid_cell_px", p.gridCellPx, 8, 400);
  p.gridMinSupport = r.integer("grid_min_support", p.gridMinSupport, 0, 50);
  p.tauPx = r.number("tau_px", p.tauPx, 0.5, 20);
  p.minMatches = r.integer("min_matches", p.minMatches, 3, 1000);
  p.edgeLow = r.number("edge_low", p.edgeLow, 1, 1000);
  p.edgeHigh = r.number("edge_high", p.edgeHigh, 1, 1000);
  p.minGradient = r.number("min_gradient", p.minGradient, 1, 1000);
  p.maxPoints = r.integer("max_points", p.maxPoints, 50, 20000);
  p.autoRegions = r.integer("auto_regions", p.autoRegions, 1, 16);
  p.rDeg = r.number("r_deg", p.rDeg, 0.1, 45);
  p.lFraction = r.number("l_fraction", p.lFraction, 0.01, 1);
  p.perHeightShift = r.flag("per_height_shift", p.perHeightShift);
  const std::string init = r.word("initial_pose", "auto", {"auto", "orb", "gradient"});
  p.init = init == "orb" ? CwParams::Init::Orb : init == "gradient" ? CwParams::Init::Gradient : CwParams::Init::Auto;
  p.minTemplateKeypoints = r.integer("min_template_keypoints", p.minTemplateKeypoints, 3, 20000);
  p.autoOrbMatches = r.integer("auto_orb_matches", p.autoOrbMatches, 3, 1000);
  p.initMinScore = r.number("init_min_score", p.initMinScore, 0.1, 1);
  if (auto ok = r.finish(); !ok) return std::unexpected(ok.error());
  if (p.edgeHigh < p.edgeLow) return fail(Status::BadArgument, name + ": parameter 'edge_high' must not be below 'edge_low'");

  const auto outline = templatePart(templateGray, p.threshold);
  const double partArea = outline.empty() ? 0.0 : cv::contourArea(outline);
  if (partArea < 100)
    return fail(Status::BadArgument, name + ": no part found in the template image (segmentation; check 'threshold')");
  cv::Point2f centre;
  float circumRadius = 0;
  cv::minEnclosingCircle(outline, centre, circumRadius);

  // Template ORB features, on the part (its outline grown by 12 px).
  cv::Mat partMask(templateGray.size(), CV_8U, cv::Scalar(0));
  cv::drawContours(partMask, std::vector<std::vector<cv::Point>>{outline}, 0, cv::Scalar(255), cv::FILLED);
  cv::Mat grownMask;
  cv::dilate(partMask, grownMask, cv::getStructuringElement(cv::MORPH_ELLIPSE, {23, 23}));
  Features tmpl = detail::detectOrb(templateGray, grownMask, p.orb.templateFeatures, p.orb);
  const int keypoints = static_cast<int>(tmpl.keypoints.size());
  if (p.init == CwParams::Init::Orb && keypoints < p.minMatches)
    return fail(Status::BadArgument, fmt::format("{}: only {} ORB features in the template ({} needed): too little texture "
                                                 "for initial_pose orb (auto or gradient need none)",
                                                 name, keypoints, p.minMatches));
  const bool useOrb = p.init == CwParams::Init::Orb ||
                      (p.init == CwParams::Init::Auto && keypoints >= std::max(p.minMatches, p.minTemplateKeypoints));

  // The texture-free initial pose: the shape matcher's gradient-direction search (its public
  // Locator), on the same template, grasp point, regions and angle range (widened by r so a
  // part at the range's edge still gets an initial pose); only its own default parameters.
  std::unique_ptr<Locator> gradient;
  if (p.init != CwParams::Init::Orb) {
    TaughtTemplate g;
    g.grasp = taught.grasp;
    g.minScore = p.initMinScore;
    g.maxParts = std::min(64, 2 * taught.maxParts + 2);
    g.angleMinDeg = std::max(-180.0, taught.angleMinDeg - p.rDeg);
    g.angleMaxDeg = std::min(180.0, taught.angleMaxDeg + p.rDeg);
    g.regions = taught.regions;
    auto made = makeShapeLocator(templateGray, g);
    if (!made) {
      if (!useOrb)
        return fail(Status::BadArgument, fmt::format("{}: {} ORB features in the template and no gradient search for the "
                                                     "initial pose ({})", name, keypoints, made.error().message));
    } else {
      gradient = std::move(*made);
    }
  }

  // The contour: pixels with a significant gradient (Canny edges) on the part, with their
  // gradients (section III.B, first paragraph).
  cv::Mat blurred, gx, gy, edges;
  cv::GaussianBlur(templateGray, blurred, cv::Size(), 1.0);
  cv::Sobel(blurred, gx, CV_32F, 1, 0, 3);
  cv::Sobel(blurred, gy, CV_32F, 0, 1, 3);
  cv::Canny(blurred, edges, p.edgeLow, p.edgeHigh, 3, true);
  edges &= grownMask;
  std::vector<cv::Point> edgePts;
  cv::findNonZero(edges, edgePts);
  std::vector<cv::Point> kept;
  for (const cv::Point& e : edgePts)
    if (std::hypot(gx.at<float>(e), gy.at<float>(e)) >= p.minGradient) kept.push_back(e);
  const size_t stride = std::max<size_t>(1, (kept.size() + static_cast<size_t>(p.maxPoints) - 1) / static_cast<size_t>(p.maxPoints));
  std::vector<cv::Point> pts;
  for (size_t k = 0; k < kept.size(); k += stride) pts.push_back(kept[k]);
  if (pts.size() < 20)
    return fail(Status::BadArgument, fmt::format("{}: only {} contour points in the template (check 'edge_low'/'edge_high')",
                                                 name, pts.size()));

  // Regions (Fig. 5): the job's polygons with their height factors epsilon, or, when the job
  // gives none, a split by position (k-means of the contour points, epsilon = 1).
  std::vector<int> region(pts.size(), -1);
  std::vector<double> epsilon;
  if (!taught.regions.empty()) {
    for (size_t j = 0; j < taught.regions.size(); ++j) {
      const auto& reg = taught.regions[j];
      if (reg.polygon.size() < 3)
        return fail(Status::BadArgument, fmt::format("{}: region {} has fewer than 3 polygon points", name, j + 1));
      if (!(reg.heightFactor >= 0 && reg.heightFactor <= 1))
        return fail(Status::BadArgument, fmt::format("{}: region {} height factor {} is not in [0, 1]", name, j + 1, reg.heightFactor));
      epsilon.push_back(reg.heightFactor);
    }
    // Regions nest (a boss's top face lies inside the base plate's): a point belongs to the
    // smallest polygon it lies in or within kRegionEdgePx of (its own edge pixels straddle
    // the polygon's boundary).
    constexpr double kRegionEdgePx = 2.5;
    std::vector<std::vector<cv::Point2f>> polys;
    std::vector<double> areas;
    for (const auto& reg : taught.regions) {
      polys.emplace_back();
      for (const auto& q : reg.polygon) polys.back().emplace_back(static_cast<float>(q.u), static_cast<float>(q.v));
      areas.push_back(std::abs(cv::contourArea(polys.back())));
    }
    for (size_t k = 0; k < pts.size(); ++k)
      for (size_t j = 0; j < polys.size(); ++j)
        if (cv::pointPolygonTest(polys[j], cv::Point2f(pts[k]), true) >= -kRegionEdgePx &&
            (region[k] < 0 || areas[j] < areas[static_cast<size_t>(region[k])]))
          region[k] = static_cast<int>(j);
  } else {
    const int K = std::min<int>(p.autoRegions, static_cast<int>(pts.size()));
    cv::Mat data(static_cast<int>(pts.size()), 2, CV_32F);
    for (size_t k = 0; k < pts.size(); ++k) {
      data.at<float>(static_cast<int>(k), 0) = static_cast<float>(pts[k].x);
      data.at<float>(static_cast<int>(k), 1) = static_cast<float>(pts[k].y);
    }
    cv::Mat labels;
    if (K > 1) {
      cv::RNG& rng = cv::theRNG();
      const cv::RNG saved = rng;
      rng = cv::RNG(0x5eed);  // the same regions every time the job loads
      cv::kmeans(data, K, labels, cv::TermCriteria(cv::TermCriteria::COUNT + cv::TermCriteria::EPS, 50, 0.1), 3,
                 cv::KMEANS_PP_CENTERS);
      rng = saved;
    } else {
      labels = cv::Mat::zeros(data.rows, 1, CV_32S);
    }
    for (size_t k = 0; k < pts.size(); ++k) region[k] = labels.at<int>(static_cast<int>(k));
    epsilon.assign(static_cast<size_t>(K), 1.0);
  }

  // Eq. (4): d_i, the mean distance of region i's contour points to the grasp point.
  const size_t m = epsilon.size();
  std::vector<double> dsum(m, 0), n(m, 0);
  for (size_t k = 0; k < pts.size(); ++k)
    if (region[k] >= 0) {
      dsum[static_cast<size_t>(region[k])] += std::hypot(pts[k].x - taught.grasp.u, pts[k].y - taught.grasp.v);
      ++n[static_cast<size_t>(region[k])];
    }
  std::vector<double> di(m, 0);
  double sumD = 0;
  size_t used = 0;
  for (size_t j = 0; j < m; ++j)
    if (n[j] > 0) {
      di[j] = dsum[j] / n[j];
      sumD += di[j];
      ++used;
    }
  // Eq. (3): w_j = (sum_i d_i - d_j) eps_j / sum_j ((sum_i d_i - d_j) eps_j); one region: w = 1.
  std::vector<double> w(m, 0);
  double wsum = 0;
  for (size_t j = 0; j < m; ++j)
    if (n[j] > 0) {
      w[j] = (used == 1 ? 1.0 : sumD - di[j]) * epsilon[j];
      wsum += w[j];
    }
  if (!(wsum > 0)) return fail(Status::BadArgument, name + ": every contour region has weight 0 (height factors, or no contour inside the regions)");
  // Height groups (see searchGrid): regions of one height share a translation; without
  // per_height_shift, or without taught regions (heights unknown), there is one group.
  std::vector<double> regionHeight(m, 0.0);
  if (!taught.regions.empty())
    for (size_t j = 0; j < m; ++j) regionHeight[j] = taught.regions[j].heightMm;
  std::vector<double> heights;
  std::vector<size_t> groupOf(m, 0);
  for (size_t j = 0; j < m; ++j) {
    if (!p.perHeightShift || n[j] == 0 || w[j] <= 0) continue;
    auto it = std::find_if(heights.begin(), heights.end(), [&](double h) { return std::abs(h - regionHeight[j]) < 1e-6; });
    groupOf[j] = static_cast<size_t>(it - heights.begin());
    if (it == heights.end()) heights.push_back(regionHeight[j]);
  }
  const size_t groupCount = std::max<size_t>(1, heights.size());
  // The grasp point's group: that of the region with the largest height factor (the grasp
  // height, eq. 4's epsilon = 1), the heavier group on a tie.
  std::vector<double> groupWeight(groupCount, 0.0), groupEps(groupCount, -1.0);
  for (size_t j = 0; j < m; ++j)
    if (n[j] > 0 && w[j] > 0) {
      groupWeight[groupOf[j]] += w[j];
      groupEps[groupOf[j]] = std::max(groupEps[groupOf[j]], epsilon[j]);
    }
  size_t graspGroup = 0;
  for (size_t g = 1; g < groupCount; ++g)
    if (groupEps[g] > groupEps[graspGroup] || (groupEps[g] == groupEps[graspGroup] && groupWeight[g] > groupWeight[graspGroup]))
      graspGroup = g;

  std::vector<std::vector<ContourPoint>> groups(groupCount);
  size_t modelPoints = 0;
  for (size_t k = 0; k < pts.size(); ++k) {
    if (region[k] < 0) continue;
    const size_t j = static_cast<size_t>(region[k]);
    if (w[j] <= 0) continue;
    const float tx = gx.at<float>(pts[k]), ty = gy.at<float>(pts[k]);
    const float mag = std::hypot(tx, ty);
    groups[groupOf[j]].push_back({cv::Point2f(static_cast<float>(pts[k].x - taught.grasp.u), static_cast<float>(pts[k].y - taught.grasp.v)),
                                  cv::Point2f(tx / mag, ty / mag), static_cast<float>(w[j] / wsum / n[j])});
    ++modelPoints;
  }
  if (modelPoints < 20) return fail(Status::BadArgument, name + ": fewer than 20 weighted contour points in the template");
  return std::make_unique<ContourWeightedLocator>(taught, std::move(p), std::move(tmpl), useOrb, std::move(gradient),
                                                  std::move(groups), graspGroup, partArea, static_cast<double>(circumRadius));
}

}  // namespace vgr::vision
