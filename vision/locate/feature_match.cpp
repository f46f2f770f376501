#include "vision/locate/feature_match.hpp"

#include <algorithm>
#include <cmath>
#include <fmt/core.h>
#include <limits>
#include <numbers>

#include <opencv2/calib3d.hpp>
#include <opencv2/flann.hpp>
#include <opencv2/imgproc.hpp>

#include "core/angles.hpp"

namespace vgr::vision::detail {

cv::Rect searchRect(const cv::Mat& gray, const TaughtTemplate& taught) {
  cv::Rect roi(0, 0, gray.cols, gray.rows);
  if (!taught.searchRoi.empty())
    roi &= cv::Rect(taught.searchRoi.x, taught.searchRoi.y, taught.searchRoi.width, taught.searchRoi.height);
  return roi;
}

void readOrbParams(ParamReader& r, OrbParams& p) {
  p.templateFeatures = r.integer("template_features", p.templateFeatures, 50, 20000);
  p.imageFeatures = r.integer("image_features", p.imageFeatures, 50, 50000);
  p.scaleFactor = r.number("orb_scale_factor", p.scaleFactor, 1.01, 2.0);
  p.levels = r.integer("orb_levels", p.levels, 1, 8);
  p.fastThreshold = r.integer("fast_threshold", p.fastThreshold, 1, 100);
}

void applyScaleRange(const TaughtTemplate& taught, OrbParams& orb, FeatureSearch& search) {
  search.scaleMin = taught.scaleMin, search.scaleMax = taught.scaleMax;
  const double spread = std::max(taught.scaleMax, 1.0 / taught.scaleMin);
  if (spread > 1.0)
    orb.levels = std::min(16, orb.levels + static_cast<int>(std::ceil(std::log(spread) / std::log(orb.scaleFactor) - 1e-9)));
}

Features detectOrb(const cv::Mat& gray, const cv::Mat& mask, int nFeatures, const OrbParams& p) {
  // ORB's detector is FAST-9 (TYPE_9_16) ranked by the Harris score (paper 000, eq. 1).
  auto orb = cv::ORB::create(nFeatures, static_cast<float>(p.scaleFactor), p.levels, 31, 0, 2, cv::ORB::HARRIS_SCORE,
                             31, p.fastThreshold);
  Features f;
  orb->detectAndCompute(gray, mask, f.keypoints, f.descriptors);
  return f;
}

namespace {

// Nearest neighbour of every row of `query` among the rows of `train` (FLANN, LSH index):
// (train row, distance) or (-1, inf) where LSH found none.
std::vector<std::pair<int, float>> flannNearest(const cv::Mat& query, const cv::Mat& train) {
  std::vector<std::pair<int, float>> out(static_cast<size_t>(query.rows), {-1, std::numeric_limits<float>::infinity()});
  if (query.empty() || train.rows < 2) return out;
  cv::FlannBasedMatcher matcher(cv::makePtr<cv::flann::LshIndexParams>(12, 20, 2), cv::makePtr<cv::flann::SearchParams>(64));
  std::vector<std::vector<cv::DMatch>> knn;
  matcher.knnMatch(query, train, knn, 1);
  for (size_t q = 0; q < knn.size() && q < out.size(); ++q)
    if (!knn[q].empty()) out[q] = {knn[q][0].trainIdx, knn[q][0].distance};
  return out;
}

// Paper 001: keep a pair when D < T = mu * minD (minD over this direction's pairs).
void gate(std::vector<std::pair<int, float>>& nn, double mu, double minDFloor) {
  float minD = std::numeric_limits<float>::infinity();
  for (const auto& [j, d] : nn)
    if (j >= 0) minD = std::min(minD, d);
  if (!std::isfinite(minD)) return;
  const double T = mu * std::max<double>(minD, minDFloor);
  for (auto& [j, d] : nn)
    if (j >= 0 && d >= T) j = -1;
}

}  // namespace

std::vector<Match> matchBidirectional(const Features& tmpl, const Features& img, const std::vector<char>& alive,
                                      double mu, double minDFloor) {
  // The image keypoints still free, packed so FLANN sees only them.
  std::vector<int> index;
  for (size_t k = 0; k < img.keypoints.size(); ++k)
    if (alive[k]) index.push_back(static_cast<int>(k));
  if (index.size() < 2 || tmpl.descriptors.rows < 2) return {};
  cv::Mat imgDesc(static_cast<int>(index.size()), img.descriptors.cols, img.descriptors.type());
  for (size_t r = 0; r < index.size(); ++r) img.descriptors.row(index[r]).copyTo(imgDesc.row(static_cast<int>(r)));

  auto forward = flannNearest(tmpl.descriptors, imgDesc);   // I1 -> I2
  auto backward = flannNearest(imgDesc, tmpl.descriptors);  // I2 -> I1
  gate(forward, mu, minDFloor);
  gate(backward, mu, minDFloor);

  std::vector<Match> out;
  for (size_t t = 0; t < forward.size(); ++t) {
    const auto [r, d] = forward[t];
    if (r < 0 || backward[static_cast<size_t>(r)].first != static_cast<int>(t)) continue;  // symmetric check
    out.push_back({static_cast<int>(t), index[static_cast<size_t>(r)], d});
  }
  std::stable_sort(out.begin(), out.end(), [](const Match& a, const Match& b) { return a.distance < b.distance; });
  return out;
}

std::vector<Match> matchNearest(const Features& tmpl, const Features& img, const std::vector<char>& alive) {
  std::vector<int> index;
  for (size_t k = 0; k < img.keypoints.size(); ++k)
    if (alive[k]) index.push_back(static_cast<int>(k));
  if (index.size() < 2 || tmpl.descriptors.rows < 2) return {};
  cv::Mat imgDesc(static_cast<int>(index.size()), img.descriptors.cols, img.descriptors.type());
  for (size_t r = 0; r < index.size(); ++r) img.descriptors.row(index[r]).copyTo(imgDesc.row(static_cast<int>(r)));
  const auto forward = flannNearest(tmpl.descriptors, imgDesc);
  std::vector<Match> out;
  for (size_t t = 0; t < forward.size(); ++t)
    if (forward[t].first >= 0) out.push_back({static_cast<int>(t), index[static_cast<size_t>(forward[t].first)], forward[t].second});
  std::stable_sort(out.begin(), out.end(), [](const Match& a, const Match& b) { return a.distance < b.distance; });
  return out;
}

std::vector<Match> coarseMatches(const Features& tmpl, const Features& img, const std::vector<char>& alive,
                                 const FeatureSearch& search) {
  return search.symmetric ? matchBidirectional(tmpl, img, alive, search.mu, search.minDFloor) : matchNearest(tmpl, img, alive);
}

bool poseFromHomography(const cv::Matx33d& H, PixelPoint grasp, double minScale, double maxScale, Detection& out) {
  const cv::Vec3d p = H * cv::Vec3d(grasp.u, grasp.v, 1.0);
  if (std::abs(p[2]) < 1e-9) return false;
  const double u = p[0] / p[2], v = p[1] / p[2];  // paper 001, eq. (15)
  // Jacobian of the projective map at the grasp point: d(x'/w)/dx = (H_0x - u H_2x) / w.
  const double j00 = (H(0, 0) - u * H(2, 0)) / p[2], j01 = (H(0, 1) - u * H(2, 1)) / p[2];
  const double j10 = (H(1, 0) - v * H(2, 0)) / p[2], j11 = (H(1, 1) - v * H(2, 1)) / p[2];
  const double det = j00 * j11 - j01 * j10;
  if (!(det > 0)) return false;  // mirrored or collapsed
  const double scale = std::sqrt(det);
  if (scale > maxScale || scale < minScale) return false;
  out.u = u;
  out.v = v;
  out.scale = scale;
  // A turn counter-clockwise as displayed by a maps (x, y) -> (x cos a + y sin a, -x sin a + y cos a)
  // (y down), so J10 - J01 = -2 sin a and J00 + J11 = 2 cos a.
  out.angleDeg = normaliseDeg(-std::atan2(j10 - j01, j00 + j11) * 180.0 / std::numbers::pi);
  return true;
}

std::vector<cv::Point2f> keypointHull(const Features& f) {
  std::vector<cv::Point2f> pts, hull;
  for (const auto& k : f.keypoints) pts.push_back(k.pt);
  if (pts.size() >= 3) cv::convexHull(pts, hull);
  return hull;
}

Result<double> selfMatchInliers(const cv::Mat& templateGray, const Features& tmpl, const OrbParams& orb,
                                const FeatureSearch& search, const FitFn& fit) {
  // The template turned by 30 degrees on a canvas that holds all of it; the border is the
  // template's own mean border gray so that the canvas edge adds no corners.
  const cv::Point2f c(0.5f * static_cast<float>(templateGray.cols - 1), 0.5f * static_cast<float>(templateGray.rows - 1));
  cv::Mat R = cv::getRotationMatrix2D(c, 30.0, 1.0);
  const cv::Rect2f box = cv::RotatedRect(c, cv::Size2f(templateGray.size()), 30.0f).boundingRect2f();
  R.at<double>(0, 2) += box.width / 2.0 - c.x;
  R.at<double>(1, 2) += box.height / 2.0 - c.y;
  cv::Mat borderMask(templateGray.size(), CV_8U, cv::Scalar(1));
  if (templateGray.cols > 4 && templateGray.rows > 4)
    borderMask(cv::Rect(2, 2, templateGray.cols - 4, templateGray.rows - 4)).setTo(0);
  const double fill = cv::mean(templateGray, borderMask)[0];
  cv::Mat turned;
  cv::warpAffine(templateGray, turned, R, cv::Size(static_cast<int>(std::ceil(box.width)), static_cast<int>(std::ceil(box.height))),
                 cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(fill));
  // Sensor noise as on a typical live image (sigma 5 gray levels, fixed seed): the
  // reference is what a good live image gives, not what a noise-free copy gives.
  cv::Mat noise(turned.size(), CV_16S);
  cv::RNG(0x5eed).fill(noise, cv::RNG::NORMAL, 0.0, 5.0);
  cv::Mat noisy;
  cv::add(turned, noise, noisy, cv::noArray(), CV_8U);
  const Features img = detectOrb(noisy, cv::Mat(), orb.imageFeatures, orb);
  const std::vector<char> alive(img.keypoints.size(), 1);
  const auto candidates = coarseMatches(tmpl, img, alive, search);
  const auto found = candidates.size() >= 4 ? fit(candidates, tmpl, img) : std::nullopt;
  const double n = found ? static_cast<double>(found->accepted.size()) : 0.0;
  if (n < search.minInliers)
    return fail(Status::BadArgument,
                fmt::format("{}: the template does not find itself turned by 30 degrees ({} matches accepted, {} needed): "
                            "too few ORB features (texture) in the template",
                            search.method, n, search.minInliers));
  return 0.5 * n;
}

Result<LocateOutput> locateFeatureParts(const cv::Mat& gray, const TaughtTemplate& taught, const Features& tmpl,
                                        const std::vector<cv::Point2f>& templateHull, const OrbParams& orb,
                                        const FeatureSearch& search, const FitFn& fit) {
  if (gray.empty() || gray.type() != CV_8UC1)
    return fail(Status::BadArgument, fmt::format("{}: expected a non-empty 8-bit gray image", search.method));
  const cv::Rect roi = searchRect(gray, taught);
  LocateOutput out;
  if (roi.empty()) return out;
  const Features img = detectOrb(gray(roi), cv::Mat(), orb.imageFeatures, orb);
  std::vector<char> alive(img.keypoints.size(), 1);
  cv::Point2f hullCentre;
  float hullRadius = 0;
  if (!templateHull.empty()) cv::minEnclosingCircle(templateHull, hullCentre, hullRadius);

  struct Found {
    Detection d;
    std::vector<MatchPair> pairs;
    int candidates = 0;
  };
  std::vector<Found> found;
  const cv::Point2f offset(static_cast<float>(roi.x), static_cast<float>(roi.y));
  // Each round takes at least the accepted keypoints away, so this ends; a few extra rounds
  // allow for fits that are rejected (out of the angle range, too weak) before a real part.
  int misses = 0;  // rounds whose fit was too weak: after three in a row the image is done
  for (int round = 0; round < 2 * taught.maxParts + 4 && static_cast<int>(found.size()) < taught.maxParts; ++round) {
    const auto candidates = coarseMatches(tmpl, img, alive, search);
    if (static_cast<int>(candidates.size()) < std::max(4, search.minInliers)) break;
    const auto fitted = fit(candidates, tmpl, img);
    if (!fitted) break;
    if (static_cast<int>(fitted->accepted.size()) < search.minInliers) {
      if (fitted->consumed.empty() || ++misses >= 3) break;
      for (int i : fitted->consumed) alive[static_cast<size_t>(i)] = 0;
      continue;
    }
    misses = 0;

    // Take away the image keypoints of this part: inside the template outline through H
    // (grown by 4 px) and every accepted one.
    std::vector<cv::Point2f> outline;
    if (templateHull.size() >= 3) cv::perspectiveTransform(templateHull, outline, cv::Mat(fitted->H));
    for (size_t k = 0; k < img.keypoints.size(); ++k)
      if (alive[k] && outline.size() >= 3 && cv::pointPolygonTest(outline, img.keypoints[k].pt, true) > -4.0) alive[k] = 0;
    for (const Match& m : fitted->accepted) alive[static_cast<size_t>(m.i)] = 0;

    Found f;
    if (!poseFromHomography(fitted->H, taught.grasp, search.scaleMin / search.maxScale, search.scaleMax * search.maxScale, f.d))
      continue;
    f.d.u += roi.x;
    f.d.v += roi.y;
    // A fixed-scale job's parts are at its scale: the fit's scale within the tolerance
    // (max_scale) is noise, which partPoses would otherwise turn into a height.
    if (search.scaleMax <= search.scaleMin) f.d.scale = search.scaleMin;
    const std::size_t support = std::max(fitted->support, fitted->accepted.size());
    f.d.score = std::clamp(static_cast<double>(support) / search.fullScoreInliers, 0.0, 1.0);
    if (f.d.score < taught.minScore || f.d.angleDeg < taught.angleMinDeg || f.d.angleDeg > taught.angleMaxDeg) continue;
    // A second fit on the same part (the rest of a part whose features at another height
    // disagree with the first fit) is not another part.
    const bool duplicate = std::any_of(found.begin(), found.end(), [&](const Found& o) {
      return std::hypot(o.d.u - f.d.u, o.d.v - f.d.v) < 0.5 * hullRadius;
    });
    if (duplicate) continue;
    f.candidates = static_cast<int>(candidates.size());
    for (const Match& m : fitted->accepted) {
      const cv::Point2f tp = tmpl.keypoints[static_cast<size_t>(m.t)].pt;
      const cv::Point2f ip = img.keypoints[static_cast<size_t>(m.i)].pt + offset;
      f.pairs.push_back({{tp.x, tp.y}, {ip.x, ip.y}});
    }
    found.push_back(std::move(f));
  }
  std::stable_sort(found.begin(), found.end(), [](const Found& a, const Found& b) { return a.d.score > b.d.score; });
  for (const Found& f : found) out.parts.push_back(f.d);
  if (!found.empty()) {
    out.matches = found.front().pairs;
    out.candidateMatches = found.front().candidates;
  }
  return out;
}

std::optional<PartFit> robustHomography(const std::vector<Match>& candidates, const Features& tmpl,
                                        const Features& img, int robust, double thresholdPx, int maxIters,
                                        double confidence) {
  if (candidates.size() < 4) return std::nullopt;
  std::vector<cv::Point2f> src, dst;
  src.reserve(candidates.size());
  dst.reserve(candidates.size());
  for (const Match& m : candidates) {
    src.push_back(tmpl.keypoints[static_cast<size_t>(m.t)].pt);
    dst.push_back(img.keypoints[static_cast<size_t>(m.i)].pt);
  }
  std::vector<unsigned char> mask;
  const cv::Mat H = cv::findHomography(src, dst, robust, thresholdPx, mask, maxIters, confidence);
  if (H.empty()) return std::nullopt;
  PartFit fit;
  fit.H = cv::Matx33d(H);
  for (size_t k = 0; k < candidates.size() && k < mask.size(); ++k)
    if (mask[k]) fit.accepted.push_back(candidates[k]);
  return fit;
}

}  // namespace vgr::vision::detail
