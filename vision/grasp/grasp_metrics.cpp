#include "vision/grasp/grasp_metrics.hpp"

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include <opencv2/imgproc.hpp>

namespace vgr::vision::grasp {
namespace {

cv::RotatedRect toCv(const GraspRect& r) {
  // cv::RotatedRect's angle turns clockwise as displayed (image y down); ours counter-clockwise.
  return cv::RotatedRect(cv::Point2f(static_cast<float>(r.u), static_cast<float>(r.v)),
                         cv::Size2f(static_cast<float>(r.widthPx), static_cast<float>(r.jawPx)), static_cast<float>(-r.angleDeg));
}

double pointSegmentPx(double px, double py, const GraspRect& a, const GraspRect& b) {
  const double dx = b.u - a.u, dy = b.v - a.v, len2 = dx * dx + dy * dy;
  const double t = len2 > 0 ? std::clamp(((px - a.u) * dx + (py - a.v) * dy) / len2, 0.0, 1.0) : 0.0;
  return std::hypot(px - (a.u + t * dx), py - (a.v + t * dy));
}

}  // namespace

double angleDiffDeg(double a, double b) {
  double d = std::fmod(std::abs(a - b), 180.0);
  return d > 90 ? 180 - d : d;
}

double rectIou(const GraspRect& a, const GraspRect& b) {
  if (!(a.widthPx > 0 && a.jawPx > 0 && b.widthPx > 0 && b.jawPx > 0)) return 0;
  std::vector<cv::Point2f> region;
  const int kind = cv::rotatedRectangleIntersection(toCv(a), toCv(b), region);
  if (kind == cv::INTERSECT_NONE || region.size() < 3) return 0;
  std::vector<cv::Point2f> hull;
  cv::convexHull(region, hull);
  const double inter = cv::contourArea(hull);
  const double uni = a.widthPx * a.jawPx + b.widthPx * b.jawPx - inter;
  return uni > 0 ? std::clamp(inter / uni, 0.0, 1.0) : 0;
}

GraspScore scoreGrasp(const GraspRect& d, const std::vector<TruthRect>& truth, const RectMetric& m) {
  GraspScore s;
  if (truth.empty()) return s;
  std::set<int> matchedLines;
  int bestIdx = -1;
  for (std::size_t i = 0; i < truth.size(); ++i) {
    const double ad = angleDiffDeg(d.angleDeg, truth[i].rect.angleDeg);
    if (ad > m.maxAngleDeg) continue;
    const double iou = rectIou(d, truth[i].rect);
    if (iou > s.bestIou) s.bestIou = iou, bestIdx = static_cast<int>(i);
    if (iou >= m.minIou) matchedLines.insert(truth[i].polyline);
  }
  s.rectSuccess = !matchedLines.empty();
  if (s.rectSuccess) {
    s.angleErrDeg = angleDiffDeg(d.angleDeg, truth[static_cast<std::size_t>(bestIdx)].rect.angleDeg);
  } else {
    double nearest = 1e300;
    for (const auto& t : truth) {
      const double dist = std::hypot(t.rect.u - d.u, t.rect.v - d.v);
      if (dist < nearest) nearest = dist, s.angleErrDeg = angleDiffDeg(d.angleDeg, t.rect.angleDeg);
    }
    return s;
  }
  // Position: distance to the polylines of the matched grasps (consecutive samples joined).
  std::map<int, std::map<int, const TruthRect*>> lines;
  for (const auto& t : truth)
    if (matchedLines.count(t.polyline)) lines[t.polyline][t.sample] = &t;
  double best = 1e300;
  for (const auto& [id, samples] : lines) {
    for (auto it = samples.begin(); it != samples.end(); ++it) {
      const TruthRect& a = *it->second;
      const double mmPerPx = a.fx > 0 ? a.depthMm / a.fx : 0;
      best = std::min(best, std::hypot(d.u - a.rect.u, d.v - a.rect.v) * mmPerPx);
      auto next = std::next(it);
      if (next != samples.end() && next->first == it->first + 1)
        best = std::min(best, pointSegmentPx(d.u, d.v, a.rect, next->second->rect) * mmPerPx);
    }
  }
  s.posErrMm = best;
  return s;
}

}  // namespace vgr::vision::grasp
