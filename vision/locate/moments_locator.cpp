#include "vision/locate/moments_locator.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
#include <memory>
#include <numbers>
#include <optional>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/angles.hpp"
#include "vision/locate/params.hpp"

namespace vgr::vision {
namespace {

// Scale- and rotation-invariant shape of a blob from its (grey-weighted) moments, to compare
// a live blob with the template's: compactness h1 = (mu20 + mu02) / m00^2 (Hu's first
// invariant; 1/(2 pi) for a disc), anisotropy of the second moments (0 for a disc, -> 1 for a
// line) and skewness along the major axis (0 for a shape symmetric about its minor axis).
struct BlobShape {
  double areaPx = 0, compactness = 0, anisotropy = 0, skew = 0;
};

struct Blob {
  Detection detection;
  BlobShape shape;
};

// The blobs of one sense (Bright or Dark) appended to `out`.
void findBlobsOfSense(const cv::Mat& gray, const MomentsParams& params, BlobSense sense, std::vector<Blob>& out) {
  cv::Mat binary;
  segment(gray, params.threshold, sense, binary);

  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(binary, labels, stats, centroids, 8, CV_32S);

  // +1: the part is brighter than the belt, -1: darker. The grey weights below,
  // (gray - bg) / (fg - bg), are the part's coverage in both cases.
  const double sign = sense == BlobSense::Dark ? -1.0 : 1.0;
  const cv::Mat kernel = cv::getStructuringElement(cv::MORPH_RECT, {3, 3});
  for (int i = 1; i < n; ++i) {
    const double area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (area < params.minAreaPx || area > params.maxAreaPx) continue;
    const cv::Rect box(stats.at<int>(i, cv::CC_STAT_LEFT), stats.at<int>(i, cv::CC_STAT_TOP),
                       stats.at<int>(i, cv::CC_STAT_WIDTH), stats.at<int>(i, cv::CC_STAT_HEIGHT));
    if (box.x == 0 || box.y == 0 || box.x + box.width >= gray.cols || box.y + box.height >= gray.rows) continue;

    // Work in the blob's box grown by a margin for the anti-aliased edge.
    constexpr int kMargin = 4;
    const cv::Rect roi = (box + cv::Size(2 * kMargin, 2 * kMargin) - cv::Point(kMargin, kMargin)) &
                         cv::Rect(0, 0, gray.cols, gray.rows);
    const cv::Mat mask = labels(roi) == i;
    cv::Mat inner, support, ring;
    cv::erode(mask, inner, kernel, {-1, -1}, 2);
    cv::dilate(mask, support, kernel, {-1, -1}, 2);
    cv::dilate(mask, ring, kernel, {-1, -1}, 4);
    ring &= ~support;
    if (cv::countNonZero(inner) == 0 || cv::countNonZero(ring) == 0) continue;
    const double fg = cv::mean(gray(roi), inner)[0];
    const double bg = cv::mean(gray(roi), ring)[0];
    if (sign * (fg - bg) < 10.0) continue;  // too little contrast for a trustworthy edge

    // Grey-level weights: an edge pixel counts with the fraction of it the part covers, so
    // the moments are sub-pixel. Not clamped at 0, so background noise stays zero-mean.
    cv::Mat w;
    gray(roi).convertTo(w, CV_32F, 1.0 / (fg - bg), -bg / (fg - bg));
    w.setTo(0, ~support);
    const cv::Moments m = cv::moments(w, false);
    if (m.m00 <= 0) continue;

    Detection d;
    d.u = roi.x + m.m10 / m.m00;  // eq. (12)
    d.v = roi.y + m.m01 / m.m00;
    d.areaPx = m.m00;
    double theta = 0.5 * std::atan2(2.0 * m.mu11, m.mu20 - m.mu02);  // eq. (13), image axes (y down)
    const double c = std::cos(theta), s = std::sin(theta);
    // Third-order central moment along the major axis: its sign tells the two ends apart.
    const double m3 = c * c * c * m.mu30 + 3 * c * c * s * m.mu21 + 3 * c * s * s * m.mu12 + s * s * s * m.mu03;
    if (m3 < 0) theta += M_PI;
    d.angleDeg = normaliseDeg(-theta * 180.0 / M_PI);  // y down -> counter-clockwise as displayed

    const double half = 0.5 * (m.mu20 + m.mu02);
    const double diff = std::sqrt(0.25 * (m.mu20 - m.mu02) * (m.mu20 - m.mu02) + m.mu11 * m.mu11);
    const double anisotropy = diff / half;                     // 0 for a disc, -> 1 for a line
    const double sigmaMajor = std::sqrt((half + diff) / m.m00);  // px
    const double skew = std::abs(m3) / m.m00 / (sigmaMajor * sigmaMajor * sigmaMajor);
    // Heuristic confidence: 1 when the major axis is well defined (anisotropy >= 0.1) and
    // the ends are told apart (skewness >= 0.02; sensor noise on a blob of thousands of
    // pixels moves it by well under 0.005).
    d.score = std::min(1.0, anisotropy / 0.1) * std::min(1.0, skew / 0.02);
    out.push_back({d, {m.m00, (m.mu20 + m.mu02) / (m.m00 * m.m00), anisotropy, skew}});
  }
}

Result<std::vector<Blob>> findBlobs(const cv::Mat& gray, const MomentsParams& params) {
  if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "moments: expected a non-empty 8-bit gray image");
  std::vector<Blob> out;
  if (params.sense != BlobSense::Dark) findBlobsOfSense(gray, params, BlobSense::Bright, out);
  if (params.sense != BlobSense::Bright) findBlobsOfSense(gray, params, BlobSense::Dark, out);
  std::sort(out.begin(), out.end(), [](const Blob& a, const Blob& b) { return a.detection.score > b.detection.score; });
  return out;
}

// How far a blob's shape is from the template's: the largest relative difference of area and
// compactness and the largest absolute difference of anisotropy and skewness.
struct ShapeDifference {
  double area = 0, shape = 0;
};
ShapeDifference shapeDifference(const BlobShape& a, const BlobShape& ref) {
  return {std::abs(a.areaPx / ref.areaPx - 1),
          std::max({std::abs(a.compactness / ref.compactness - 1), std::abs(a.anisotropy - ref.anisotropy),
                    std::abs(a.skew - ref.skew)})};
}

}  // namespace

Result<std::vector<Detection>> locateByMoments(const cv::Mat& gray, const MomentsParams& params) {
  auto blobs = findBlobs(gray, params);
  if (!blobs) return std::unexpected(blobs.error());
  std::vector<Detection> out;
  out.reserve(blobs->size());
  for (const auto& b : *blobs) out.push_back(b.detection);
  return out;
}

namespace {

// "moments" with a template: the template's own blob gives the reference centroid and axis;
// a live blob's rotation is its axis minus the template's, and the grasp point is the
// template's grasp offset from the centroid turned by that rotation (y down, so a
// counter-clockwise turn as displayed by a is (x, y) -> (x cos a + y sin a, -x sin a + y cos a)).
class MomentsLocator final : public Locator {
 public:
  // A shape check: the template blob's shape and how far a live blob may be from it.
  struct ShapeCheck {
    BlobShape reference;
    double areaTolerance = 0.25, shapeTolerance = 0.1;
  };
  MomentsLocator(MomentsParams params, Detection reference, const TaughtTemplate& taught, std::optional<ShapeCheck> check)
      : params_(params), reference_(reference), taught_(taught), check_(check) {}

  std::string_view method() const override { return "moments"; }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "moments: expected a non-empty 8-bit gray image");
    cv::Rect roi(0, 0, gray.cols, gray.rows);
    if (!taught_.searchRoi.empty())
      roi &= cv::Rect(taught_.searchRoi.x, taught_.searchRoi.y, taught_.searchRoi.width, taught_.searchRoi.height);
    auto found = findBlobs(gray(roi), params_);
    if (!found) return std::unexpected(found.error());
    LocateOutput out;
    const double gx = taught_.grasp.u - reference_.u, gy = taught_.grasp.v - reference_.v;
    for (const Blob& b : *found) {
      const Detection& d = b.detection;
      if (d.score < taught_.minScore) continue;
      if (check_) {
        // Not the taught shape (another part, clutter, two parts touching): no part.
        const ShapeDifference diff = shapeDifference(b.shape, check_->reference);
        if (diff.area > check_->areaTolerance || diff.shape > check_->shapeTolerance) continue;
      }
      const double rot = normaliseDeg(d.angleDeg - reference_.angleDeg);
      if (rot < taught_.angleMinDeg || rot > taught_.angleMaxDeg) continue;
      const double a = rot * std::numbers::pi / 180.0;
      Detection p = d;
      p.u = roi.x + d.u + gx * std::cos(a) + gy * std::sin(a);
      p.v = roi.y + d.v - gx * std::sin(a) + gy * std::cos(a);
      p.angleDeg = rot;
      out.parts.push_back(p);
      if (static_cast<int>(out.parts.size()) >= taught_.maxParts) break;
    }
    return out;
  }

 private:
  MomentsParams params_;
  Detection reference_;
  TaughtTemplate taught_;
  std::optional<ShapeCheck> check_;
};

}  // namespace

Result<std::unique_ptr<Locator>> makeMomentsLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  ParamReader r("moments", taught);
  MomentsParams p;
  p.threshold = r.integer("threshold", 0, 0, 255);
  p.minAreaPx = r.number("min_area_px", p.minAreaPx, 1, 1e9);
  p.maxAreaPx = r.number("max_area_px", p.maxAreaPx, 1, 1e9);
  MomentsLocator::ShapeCheck check;
  check.areaTolerance = r.number("area_tolerance", check.areaTolerance, 0, 10);
  check.shapeTolerance = r.number("shape_tolerance", check.shapeTolerance, 0, 10);
  // shape_check: false for a job whose classifier decides what each blob is (paper 002:
  // every contour is a candidate, the MLP labels or rejects it; tools/vgr/classify.cpp).
  const bool shapeCheck = r.flag("shape_check", true);
  p.sense = readBlobPolarity(r, templateGray, p.threshold);
  if (auto ok = r.finish(); !ok) return std::unexpected(ok.error());
  if (p.maxAreaPx <= p.minAreaPx) return fail(Status::BadArgument, "moments: parameter 'max_area_px' must exceed 'min_area_px'");
  // The reference blob has the template's own sense, also when live parts may be either.
  MomentsParams own = p;
  own.sense = p.sense == BlobSense::Either ? templateSense(templateGray, p.threshold) : p.sense;
  auto ref = findBlobs(templateGray, own);
  if (!ref) return std::unexpected(ref.error());
  if (ref->empty())
    return fail(Status::BadArgument, fmt::format("moments: no {} part found in the template image (check threshold, area "
                                                 "limits and polarity)", senseName(own.sense)));
  check.reference = ref->front().shape;
  return std::make_unique<MomentsLocator>(p, ref->front().detection, taught,
                                          shapeCheck ? std::optional(check) : std::nullopt);
}

std::unique_ptr<Locator> makeUntaughtMomentsLocator(const MomentsParams& params) {
  // No template: the reference is the image origin at 0 degrees and the grasp point is the
  // blob's centroid; every blob in the area range is a part (no score floor, no count cap),
  // exactly what locateByMoments() reports.
  TaughtTemplate taught;
  taught.minScore = 0;
  taught.maxParts = std::numeric_limits<int>::max();
  return std::make_unique<MomentsLocator>(params, Detection{}, taught, std::nullopt);
}

}  // namespace vgr::vision
