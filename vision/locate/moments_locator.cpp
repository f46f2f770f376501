#include "vision/locate/moments_locator.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/angles.hpp"

namespace vgr::vision {
namespace {

}  // namespace

Result<std::vector<Detection>> locateByMoments(const cv::Mat& gray, const MomentsParams& params) {
  if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "moments: expected a non-empty 8-bit gray image");

  cv::Mat binary;
  if (params.threshold > 0)
    cv::threshold(gray, binary, params.threshold, 255, cv::THRESH_BINARY);
  else
    cv::threshold(gray, binary, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);

  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(binary, labels, stats, centroids, 8, CV_32S);

  std::vector<Detection> out;
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
    if (fg - bg < 10.0) continue;  // too little contrast for a trustworthy edge

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
    out.push_back(d);
  }
  std::sort(out.begin(), out.end(), [](const Detection& a, const Detection& b) { return a.score > b.score; });
  return out;
}

}  // namespace vgr::vision
