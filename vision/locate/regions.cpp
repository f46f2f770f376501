#include "vision/locate/regions.hpp"

#include <algorithm>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace vgr::vision {

std::vector<TemplateRegion> splitTemplateRegions(const cv::Mat& gray, int maxRegions, double minLengthPx) {
  std::vector<TemplateRegion> out;
  if (gray.empty() || gray.type() != CV_8UC1) return out;
  // Significant gradient (paper 000, Sec. III-B): Canny with thresholds from Otsu's level,
  // then close small gaps so that one physical edge is one piece.
  cv::Mat blurred, bin, edges;
  cv::GaussianBlur(gray, blurred, cv::Size(5, 5), 1.2);
  const double otsu = cv::threshold(blurred, bin, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  cv::Canny(blurred, edges, 0.25 * otsu, 0.5 * otsu);
  cv::dilate(edges, edges, cv::getStructuringElement(cv::MORPH_ELLIPSE, cv::Size(3, 3)));
  // Each connected piece of edge pixels is one contour (the outline, a rib's outline, a
  // boss's rim, ...).
  cv::Mat labels, stats, centroids;
  const int n = cv::connectedComponentsWithStats(edges, labels, stats, centroids, 8, CV_32S);
  std::vector<std::vector<cv::Point>> pieces(static_cast<std::size_t>(n));
  for (int y = 0; y < labels.rows; ++y) {
    const auto* l = labels.ptr<int>(y);
    for (int x = 0; x < labels.cols; ++x)
      if (l[x] > 0) pieces[static_cast<std::size_t>(l[x])].emplace_back(x, y);
  }
  // Largest first; a piece's size is its pixel count, about its length times the 3 px edge width.
  std::sort(pieces.begin(), pieces.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
  for (const auto& c : pieces) {
    if (static_cast<int>(out.size()) >= maxRegions) break;
    if (static_cast<double>(c.size()) < 3 * minLengthPx) continue;
    std::vector<cv::Point> hull;
    cv::convexHull(c, hull);
    TemplateRegion r;
    for (const auto& p : hull) r.polygon.push_back({static_cast<double>(p.x), static_cast<double>(p.y)});
    out.push_back(std::move(r));
  }
  return out;
}

}  // namespace vgr::vision
