#include "vision/locate/hu_sift_locators.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/core.h>
#include <opencv2/calib3d.hpp>
#include <opencv2/core.hpp>
#include <opencv2/features2d.hpp>
#include <opencv2/flann.hpp>
#include <opencv2/imgproc.hpp>

#include "core/angles.hpp"
#include "vision/locate/blob_polarity.hpp"
#include "vision/locate/params.hpp"

namespace vgr::vision {
namespace {

constexpr double kRadToDeg = 180.0 / std::numbers::pi;

cv::Rect searchRect(const TaughtTemplate& t, const cv::Mat& gray) {
  cv::Rect roi(0, 0, gray.cols, gray.rows);
  if (!t.searchRoi.empty()) roi &= cv::Rect(t.searchRoi.x, t.searchRoi.y, t.searchRoi.width, t.searchRoi.height);
  return roi;
}

// Grasp offset (template px, from the reference point) turned counter-clockwise as displayed
// by rotDeg (y down: (x, y) -> (x cos a + y sin a, -x sin a + y cos a)).
PixelPoint turn(double gx, double gy, double rotDeg) {
  const double a = rotDeg / kRadToDeg;
  return {gx * std::cos(a) + gy * std::sin(a), -gx * std::sin(a) + gy * std::cos(a)};
}

// ---- hu --------------------------------------------------------------------------------

struct HuParams {
  int threshold = 0;           // [0, 255], 0 = Otsu
  double minAreaPx = 2000;     // outer contours outside [min, max] are not candidates
  double maxAreaPx = 1e7;
  double minHoleFraction = 0.015;  // inner contours below this share of the outer area are noise
  double shapeScale = 0.15;    // matchShapes distance at which the score is 0.5
  BlobSense sense = BlobSense::Bright;  // which side of the threshold is the part (blob_polarity.hpp)
};

struct Blob {
  std::vector<cv::Point> outer;
  std::vector<std::vector<cv::Point>> holes;
  double cx = 0, cy = 0, angleDeg = 0;  // centroid px, principal axis as displayed (CCW), (-180, 180]
  BlobSense sense = BlobSense::Bright;   // the segmentation it came from (Bright or Dark)
  // Template only: binary samples around the centroid (offset px, value), to tell the two
  // directions of the principal axis apart.
  std::vector<std::pair<cv::Point2f, bool>> samples;
};

// Mean of matchShapes' I1, I2, I3 (paper 002, Hu-moment identification).
double huDistance(const std::vector<cv::Point>& a, const std::vector<cv::Point>& b) {
  return (cv::matchShapes(a, b, cv::CONTOURS_MATCH_I1, 0) + cv::matchShapes(a, b, cv::CONTOURS_MATCH_I2, 0) +
          cv::matchShapes(a, b, cv::CONTOURS_MATCH_I3, 0)) /
         3.0;
}

// Centroid (paper 002, eq. 12) and principal axis (eq. 13) of the region inside `outer`
// where bin is set (holes and dark marks excluded). The axis is 180-degree ambiguous; with
// `samples` the template's region is sampled around its centroid for resolving that.
void poseOf(const cv::Mat& bin, Blob& b, bool sample = false) {
  const cv::Rect box = cv::boundingRect(b.outer) & cv::Rect(0, 0, bin.cols, bin.rows);
  cv::Mat mask = cv::Mat::zeros(box.size(), CV_8UC1);
  cv::drawContours(mask, std::vector<std::vector<cv::Point>>{b.outer}, 0, cv::Scalar(255), cv::FILLED, cv::LINE_8,
                   cv::noArray(), 0, -box.tl());
  mask &= bin(box);
  const cv::Moments m = cv::moments(mask, true);
  if (m.m00 <= 0) return;
  b.cx = box.x + m.m10 / m.m00;
  b.cy = box.y + m.m01 / m.m00;
  const double th = 0.5 * std::atan2(2 * m.mu11, m.mu20 - m.mu02);
  b.angleDeg = normaliseDeg(-th * kRadToDeg);  // image y is down: displayed CCW is -th
  if (!sample) return;
  const int step = std::max(1, static_cast<int>(std::sqrt(box.area() / 3000.0)));
  for (int y = 0; y < mask.rows; y += step)
    for (int x = 0; x < mask.cols; x += step)
      b.samples.push_back({cv::Point2f(static_cast<float>(box.x + x - b.cx), static_cast<float>(box.y + y - b.cy)), mask.at<std::uint8_t>(y, x) != 0});
}

// Share of the template's samples that agree with `bin` when the template is turned by
// rotDeg (CCW as displayed) about its centroid and put on (cx, cy).
double agreement(const Blob& ref, const cv::Mat& bin, double cx, double cy, double rotDeg) {
  int agree = 0, n = 0;
  for (const auto& [p, on] : ref.samples) {
    const PixelPoint q = turn(p.x, p.y, rotDeg);
    const int x = cvRound(cx + q.u), y = cvRound(cy + q.v);
    if (x < 0 || y < 0 || x >= bin.cols || y >= bin.rows) continue;
    ++n;
    if ((bin.at<std::uint8_t>(y, x) != 0) == on) ++agree;
  }
  return n ? double(agree) / n : 0;
}

class HuLocator final : public Locator {
 public:
  HuLocator(HuParams p, Blob reference, const TaughtTemplate& taught) : p_(p), ref_(std::move(reference)), taught_(taught) {}
  std::string_view method() const override { return "hu"; }

  // The part blobs of one sense (Bright or Dark; bin: that segmentation, 255 = part) appended to out.
  static void blobs(const cv::Mat& gray, const HuParams& p, BlobSense sense, cv::Mat& bin, std::vector<Blob>& out) {
    segment(gray, p.threshold, sense, bin);
    std::vector<std::vector<cv::Point>> contours;
    std::vector<cv::Vec4i> hierarchy;
    cv::findContours(bin, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
    const cv::Rect inner(1, 1, gray.cols - 2, gray.rows - 2);
    for (std::size_t i = 0; i < contours.size(); ++i) {
      if (hierarchy[i][3] >= 0) continue;  // not an outer contour
      const double area = cv::contourArea(contours[i]);
      if (area < p.minAreaPx || area > p.maxAreaPx) continue;
      const cv::Rect box = cv::boundingRect(contours[i]);
      if ((box & inner) != box) continue;  // touches the border: its shape is cut
      Blob b;
      b.outer = contours[i];
      b.sense = sense;
      for (int k = hierarchy[i][2]; k >= 0; k = hierarchy[k][0])
        if (cv::contourArea(contours[k]) >= p.minHoleFraction * area) b.holes.push_back(contours[k]);
      out.push_back(std::move(b));
    }
  }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "hu: expected a non-empty 8-bit gray image");
    const cv::Rect roi = searchRect(taught_, gray);
    found_.clear();
    if (p_.sense != BlobSense::Dark) blobs(gray(roi), p_, BlobSense::Bright, binBright_, found_);
    if (p_.sense != BlobSense::Bright) blobs(gray(roi), p_, BlobSense::Dark, binDark_, found_);
    LocateOutput out;
    const double gx = taught_.grasp.u - ref_.cx, gy = taught_.grasp.v - ref_.cy;
    for (Blob& b : found_) {
      const cv::Mat& bin = b.sense == BlobSense::Dark ? binDark_ : binBright_;
      double d = huDistance(ref_.outer, b.outer);
      if (d > 20 * p_.shapeScale) continue;
      // Inner contours one-to-one: each template hole takes its closest free candidate hole
      // (shape distance plus log area ratio); a template hole left without one costs 1.
      std::vector<bool> used(b.holes.size(), false);
      for (const auto& th : ref_.holes) {
        const double ta = cv::contourArea(th);
        double best = 1.0;
        int bestK = -1;
        for (std::size_t k = 0; k < b.holes.size(); ++k) {
          if (used[k]) continue;
          const double cost = huDistance(th, b.holes[k]) + std::abs(std::log(cv::contourArea(b.holes[k]) / ta));
          if (cost < best) best = cost, bestK = static_cast<int>(k);
        }
        if (bestK >= 0) used[static_cast<std::size_t>(bestK)] = true;
        d += best;
      }
      d /= 1.0 + static_cast<double>(ref_.holes.size());
      Detection det;
      det.score = 1.0 / (1.0 + d / p_.shapeScale);
      if (det.score < taught_.minScore) continue;
      poseOf(bin, b);
      // The principal axis leaves 180 degrees open: take the turn under which the template's
      // region agrees better with this one.
      double rot = normaliseDeg(b.angleDeg - ref_.angleDeg);
      if (agreement(ref_, bin, b.cx, b.cy, normaliseDeg(rot + 180)) > agreement(ref_, bin, b.cx, b.cy, rot))
        rot = normaliseDeg(rot + 180);
      if (rot < taught_.angleMinDeg || rot > taught_.angleMaxDeg) continue;
      const PixelPoint g = turn(gx, gy, rot);
      det.u = roi.x + b.cx + g.u;
      det.v = roi.y + b.cy + g.v;
      det.angleDeg = rot;
      det.areaPx = cv::contourArea(b.outer);
      out.parts.push_back(det);
    }
    std::sort(out.parts.begin(), out.parts.end(), [](const Detection& a, const Detection& b) { return a.score > b.score; });
    if (static_cast<int>(out.parts.size()) > taught_.maxParts) out.parts.resize(static_cast<std::size_t>(taught_.maxParts));
    return out;
  }

 private:
  HuParams p_;
  Blob ref_;
  TaughtTemplate taught_;
  cv::Mat binBright_, binDark_;  // scratch, reused between calls: the segmentation of each sense
  std::vector<Blob> found_;
};

// ---- sift ------------------------------------------------------------------------------

struct SiftParams {
  int features = 0;          // SIFT nfeatures, 0 = all
  double ratio = 0.7;        // Lowe's ratio test (paper 002)
  int minMatches = 20;       // paper 002: at least 20 good matches
  int trees = 5, checks = 10;  // FLANN kd-tree (paper 002)
  double ransacPx = 3.0;     // homography inlier distance, px
  bool rigidPose = true;     // pose from a similarity through the inliers (else the homography's)
};

class SiftLocator final : public Locator {
 public:
  SiftLocator(SiftParams p, const cv::Mat& templ, const TaughtTemplate& taught)
      : p_(p), taught_(taught), sift_(cv::SIFT::create(p.features)),
        matcher_(cv::makePtr<cv::flann::KDTreeIndexParams>(p.trees), cv::makePtr<cv::flann::SearchParams>(p.checks)) {
    sift_->detectAndCompute(templ, cv::noArray(), tplKeys_, tplDesc_);
    centreKeypoints(tplKeys_);
    tplSize_ = templ.size();
    if (!tplDesc_.empty()) {
      matcher_.add(std::vector<cv::Mat>{tplDesc_});
      matcher_.train();
    }
  }
  std::string_view method() const override { return "sift"; }

  // OpenCV's SIFT doubles the image first (bilinear, pixel centres at integers: doubled
  // pixel i sits at i / 2 - 0.25) and reports every octave's keypoints as doubled
  // coordinates / 2, i.e. 0.25 px right of and below where they are. The same bias in the
  // template and the image cancels in the translation but not under rotation (the grasp
  // point came out b - R b off: ~0.3 px mean in the sim cell), so remove it.
  static void centreKeypoints(std::vector<cv::KeyPoint>& keys) {
    for (auto& k : keys) k.pt -= cv::Point2f(0.25f, 0.25f);
  }
  std::size_t templateKeypoints() const { return tplKeys_.size(); }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "sift: expected a non-empty 8-bit gray image");
    const cv::Rect roi = searchRect(taught_, gray);
    std::vector<cv::KeyPoint> keys;
    cv::Mat desc;
    sift_->detectAndCompute(gray(roi), cv::noArray(), keys, desc);
    centreKeypoints(keys);
    LocateOutput out;
    if (desc.rows < 2 || tplDesc_.empty()) return out;
    // Query: the image's descriptors, so that every instance of the part finds the template.
    std::vector<std::vector<cv::DMatch>> knn;
    matcher_.knnMatch(desc, knn, 2);
    std::vector<cv::Point2f> tp, ip;
    for (const auto& m : knn) {
      if (m.size() < 2 || m[0].distance >= p_.ratio * m[1].distance) continue;
      tp.push_back(tplKeys_[static_cast<std::size_t>(m[0].trainIdx)].pt);
      const cv::Point2f q = keys[static_cast<std::size_t>(m[0].queryIdx)].pt;
      ip.emplace_back(q.x + static_cast<float>(roi.x), q.y + static_cast<float>(roi.y));
    }
    out.candidateMatches = static_cast<int>(tp.size());
    std::vector<std::vector<MatchPair>> partMatches;
    // One part per RANSAC homography; its inliers (and every match inside its outline) are
    // removed before looking for the next.
    for (int round = 0; round < taught_.maxParts + 4 && static_cast<int>(tp.size()) >= p_.minMatches; ++round) {
      std::vector<unsigned char> inl;
      const cv::Mat h = cv::findHomography(tp, ip, cv::RANSAC, p_.ransacPx, inl, 2000, 0.995);
      if (h.empty()) break;
      const int inliers = cv::countNonZero(inl);
      if (inliers < p_.minMatches) break;
      std::vector<cv::Point2f> corners{{0, 0}, {float(tplSize_.width - 1), 0}, {float(tplSize_.width - 1), float(tplSize_.height - 1)}, {0, float(tplSize_.height - 1)}},
          mapped;
      cv::perspectiveTransform(corners, mapped, h);
      std::vector<cv::Point2f> g{{float(taught_.grasp.u), float(taught_.grasp.v)}, {float(taught_.grasp.u + 20), float(taught_.grasp.v)}}, gm;
      cv::perspectiveTransform(g, gm, h);
      const double area = std::abs(cv::contourArea(mapped)), tplArea = double(tplSize_.area());
      const bool sane = cv::isContourConvex(mapped) && area > 0.25 * tplArea && area < 4 * tplArea;
      std::vector<cv::Point2f> ntp, nip;
      std::vector<MatchPair> mine;
      for (std::size_t k = 0; k < tp.size(); ++k) {
        if (inl[k]) {
          mine.push_back({{tp[k].x, tp[k].y}, {ip[k].x, ip[k].y}});
          continue;
        }
        if (sane && cv::pointPolygonTest(mapped, ip[k], false) >= 0) continue;
        ntp.push_back(tp[k]);
        nip.push_back(ip[k]);
      }
      tp.swap(ntp);
      ip.swap(nip);
      if (!sane) continue;
      Detection d;
      d.u = gm[0].x;
      d.v = gm[0].y;
      d.angleDeg = normaliseDeg(std::atan2(-(gm[1].y - gm[0].y), gm[1].x - gm[0].x) * kRadToDeg);
      if (p_.rigidPose) {
        // The part is rigid and the camera looks straight at the conveyor: a similarity (4
        // DOF) through the homography's inliers pins the pose down better than the
        // homography's local rotation at the grasp point (8 DOF from ~30 inliers; see
        // docs/localization.md, "sift").
        std::vector<cv::Point2f> a, b;
        for (const auto& m : mine) {
          a.emplace_back(static_cast<float>(m.templatePx.u), static_cast<float>(m.templatePx.v));
          b.emplace_back(static_cast<float>(m.imagePx.u), static_cast<float>(m.imagePx.v));
        }
        const cv::Mat sim = cv::estimateAffinePartial2D(a, b, cv::noArray(), cv::LMEDS);
        if (!sim.empty()) {
          const cv::Matx23d m(sim);
          d.angleDeg = normaliseDeg(std::atan2(-m(1, 0), m(0, 0)) * kRadToDeg);
          d.u = m(0, 0) * taught_.grasp.u + m(0, 1) * taught_.grasp.v + m(0, 2);
          d.v = m(1, 0) * taught_.grasp.u + m(1, 1) * taught_.grasp.v + m(1, 2);
        }
      }
      d.score = double(inliers) / (inliers + p_.minMatches);  // 0.5 at the paper's 20 matches
      d.areaPx = area;
      if (d.score < taught_.minScore || d.angleDeg < taught_.angleMinDeg || d.angleDeg > taught_.angleMaxDeg) continue;
      out.parts.push_back(d);
      partMatches.push_back(std::move(mine));
    }
    std::vector<std::size_t> order(out.parts.size());
    for (std::size_t i = 0; i < order.size(); ++i) order[i] = i;
    std::sort(order.begin(), order.end(), [&](std::size_t a, std::size_t b) { return out.parts[a].score > out.parts[b].score; });
    std::vector<Detection> sorted;
    for (std::size_t i : order) sorted.push_back(out.parts[i]);
    if (!order.empty()) out.matches = partMatches[order.front()];
    out.parts = std::move(sorted);
    if (static_cast<int>(out.parts.size()) > taught_.maxParts) out.parts.resize(static_cast<std::size_t>(taught_.maxParts));
    return out;
  }

 private:
  SiftParams p_;
  TaughtTemplate taught_;
  cv::Ptr<cv::SIFT> sift_;
  cv::FlannBasedMatcher matcher_;
  std::vector<cv::KeyPoint> tplKeys_;
  cv::Mat tplDesc_;
  cv::Size tplSize_;
};

}  // namespace

Result<std::unique_ptr<Locator>> makeHuLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  ParamReader r("hu", taught);
  HuParams p;
  p.threshold = r.integer("threshold", p.threshold, 0, 255);
  p.minAreaPx = r.number("min_area_px", p.minAreaPx, 1, 1e9);
  p.maxAreaPx = r.number("max_area_px", p.maxAreaPx, 1, 1e9);
  p.minHoleFraction = r.number("min_hole_fraction", p.minHoleFraction, 0, 1);
  p.shapeScale = r.number("shape_scale", p.shapeScale, 1e-4, 10);
  p.sense = readBlobPolarity(r, templateGray, p.threshold);
  if (auto ok = r.finish(); !ok) return std::unexpected(ok.error());
  if (p.maxAreaPx <= p.minAreaPx) return fail(Status::BadArgument, "hu: parameter 'max_area_px' must exceed 'min_area_px'");
  if (templateGray.empty() || templateGray.type() != CV_8UC1) return fail(Status::BadArgument, "hu: expected a non-empty 8-bit gray template");
  // The reference has the template's own sense, also when live parts may be either.
  const BlobSense own = p.sense == BlobSense::Either ? templateSense(templateGray, p.threshold) : p.sense;
  cv::Mat bin;
  std::vector<Blob> found;
  HuLocator::blobs(templateGray, p, own, bin, found);
  if (found.empty())
    return fail(Status::BadArgument, fmt::format("hu: no {} part found in the template image (check threshold, area limits "
                                                 "and polarity)", senseName(own)));
  // The template's part: its largest outer contour.
  auto best = std::max_element(found.begin(), found.end(), [](const Blob& a, const Blob& b) {
    return cv::contourArea(a.outer) < cv::contourArea(b.outer);
  });
  Blob ref = *best;
  poseOf(bin, ref, true);
  return std::make_unique<HuLocator>(p, std::move(ref), taught);
}

Result<std::unique_ptr<Locator>> makeSiftLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  ParamReader r("sift", taught);
  SiftParams p;
  p.features = r.integer("features", p.features, 0, 100000);
  p.ratio = r.number("ratio", p.ratio, 0.1, 1.0);
  p.minMatches = r.integer("min_matches", p.minMatches, 4, 10000);
  p.trees = r.integer("trees", p.trees, 1, 64);
  p.checks = r.integer("checks", p.checks, 1, 10000);
  p.ransacPx = r.number("ransac_px", p.ransacPx, 0.1, 100);
  p.rigidPose = r.flag("rigid_pose", p.rigidPose);
  if (auto ok = r.finish(); !ok) return std::unexpected(ok.error());
  auto loc = std::make_unique<SiftLocator>(p, templateGray, taught);
  if (loc->templateKeypoints() < static_cast<std::size_t>(p.minMatches))
    return fail(Status::BadArgument, fmt::format("sift: the template has {} keypoints, fewer than min_matches {}",
                                                 loc->templateKeypoints(), p.minMatches));
  return loc;
}

}  // namespace vgr::vision
