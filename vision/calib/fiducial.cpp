#include "vision/calib/fiducial.hpp"

#include <cmath>

#include <fmt/core.h>
#include <opencv2/imgproc.hpp>

namespace vgr::vision::calib {

Result<FiducialFound> locateFiducial(const cv::Mat& gray, const FiducialSearch& search) {
  if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "fiducial: expected an 8-bit gray image");
  const cv::Rect window = search.window & cv::Rect(0, 0, gray.cols, gray.rows);
  if (window.width < 5 || window.height < 5)
    return fail(Status::BadArgument, fmt::format("fiducial: the search window {}x{} at ({}, {}) is not inside the {}x{} image",
                                                 search.window.width, search.window.height, search.window.x,
                                                 search.window.y, gray.cols, gray.rows));
  const cv::Mat roi = gray(window);
  cv::Mat mask;
  const double t = cv::threshold(roi, mask, 0, 255, (search.bright ? cv::THRESH_BINARY : cv::THRESH_BINARY_INV) | cv::THRESH_OTSU);
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);
  int found = -1, candidates = 0;
  for (int i = 1; i < n; ++i) {
    const int x = stats.at<int>(i, cv::CC_STAT_LEFT), y = stats.at<int>(i, cv::CC_STAT_TOP);
    const int w = stats.at<int>(i, cv::CC_STAT_WIDTH), h = stats.at<int>(i, cv::CC_STAT_HEIGHT);
    const double area = stats.at<int>(i, cv::CC_STAT_AREA);
    if (area < search.minAreaPx) continue;
    if (x == 0 || y == 0 || x + w == roi.cols || y + h == roi.rows) continue;  // cut by the window
    const double aspect = static_cast<double>(w) / h;
    const double d = std::max(w, h);
    if (aspect < 0.75 || aspect > 1.0 / 0.75 || area < 0.7 * M_PI * d * d / 4) continue;  // not round
    if (search.expectedAreaPx > 0 && std::abs(area - search.expectedAreaPx) > 0.4 * search.expectedAreaPx) continue;
    const cv::Mat blob = labels(cv::Rect(x, y, w, h)) == i;
    const double inside = cv::mean(roi(cv::Rect(x, y, w, h)), blob)[0];
    const double ground = cv::mean(roi, mask == 0)[0];
    if (std::abs(inside - ground) < search.minContrast) continue;
    ++candidates;
    found = i;
  }
  if (candidates == 0) return fail(Status::NoPartFound, "fiducial not seen in its search window");
  if (candidates > 1)
    return fail(Status::NoPartFound, fmt::format("fiducial ambiguous: {} round marks in its search window", candidates));

  // Gray-weighted centroid over the blob's box grown by 2 px (clipped to the window).
  const cv::Rect box = cv::Rect(stats.at<int>(found, cv::CC_STAT_LEFT) - 2, stats.at<int>(found, cv::CC_STAT_TOP) - 2,
                                stats.at<int>(found, cv::CC_STAT_WIDTH) + 4, stats.at<int>(found, cv::CC_STAT_HEIGHT) + 4) &
                       cv::Rect(0, 0, roi.cols, roi.rows);
  double sw = 0, su = 0, sv = 0;
  for (int y = box.y; y < box.y + box.height; ++y) {
    const auto* row = roi.ptr<std::uint8_t>(y);
    for (int x = box.x; x < box.x + box.width; ++x) {
      const double w = search.bright ? row[x] - t : t - row[x];
      if (w <= 0) continue;
      sw += w;
      su += w * x;
      sv += w * y;
    }
  }
  if (sw <= 0) return fail(Status::NoPartFound, "fiducial not seen in its search window");
  FiducialFound f;
  f.centre = {window.x + su / sw, window.y + sv / sw};
  f.areaPx = stats.at<int>(found, cv::CC_STAT_AREA);
  f.diameterPx = 2 * std::sqrt(f.areaPx / M_PI);
  return f;
}

}  // namespace vgr::vision::calib
