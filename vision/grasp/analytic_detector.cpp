#include "vision/grasp/analytic_detector.hpp"

#include <algorithm>
#include <cmath>
#include <vector>

#include <opencv2/imgproc.hpp>

namespace vgr::vision::grasp {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr int kHoleFillPasses = 4;  // closes bands of no data up to 8 px wide

class AnalyticDetector final : public GraspDetector {
 public:
  explicit AnalyticDetector(GraspDetectorOptions o) : o_(std::move(o)) {}
  std::string_view name() const override { return "analytic"; }

  Result<std::vector<Grasp>> detect(const DepthFrame& f) override {
    if (auto c = checkFrame(f); !c) return std::unexpected(c.error());
    auto floor = fitFloorPlane(f.zMm, f.camera, f.name, o_.floor);
    if (!floor) return std::unexpected(floor.error());
    const cv::Mat h = heightAboveFloor(f.zMm, f.camera, *floor);

    // Pixels without data (the sensor drops both sides of every depth jump) take the lower
    // side's height: an object is not cut into its faces, and stays apart from the floor.
    cv::Mat filled = h.clone();
    fillHolesLow(filled, kHoleFillPasses);
    cv::Mat mask = filled >= o_.minObjectHeightMm;  // NaN compares false
    cv::morphologyEx(mask, mask, cv::MORPH_OPEN, cv::getStructuringElement(cv::MORPH_RECT, cv::Size(3, 3)));
    cv::Mat labels, stats, centroids;
    const int n = cv::connectedComponentsWithStats(mask, labels, stats, centroids, 8, CV_32S);

    struct Object {
      std::vector<cv::Point> pixels;
      std::vector<float> depths;
      float top = 0;
    };
    std::vector<Object> objects(static_cast<std::size_t>(std::max(n, 1)));
    for (int y = 0; y < labels.rows; ++y)
      for (int x = 0; x < labels.cols; ++x) {
        const int l = labels.at<int>(y, x);
        if (l == 0) continue;
        auto& obj = objects[static_cast<std::size_t>(l)];
        obj.pixels.emplace_back(x, y);
        const float hv = h.at<float>(y, x);
        if (!std::isnan(hv)) {
          obj.depths.push_back(f.zMm.at<float>(y, x));
          obj.top = std::max(obj.top, hv);
        }
      }

    struct Candidate {
      Grasp g;
      float top;
    };
    std::vector<Candidate> found;
    for (int l = 1; l < n; ++l) {
      auto& obj = objects[static_cast<std::size_t>(l)];
      if (static_cast<int>(obj.pixels.size()) < o_.minObjectAreaPx || obj.depths.empty() || obj.top > o_.maxObjectHeightMm) continue;
      const cv::RotatedRect box = cv::minAreaRect(obj.pixels);
      cv::Point2f c[4];
      box.points(c);
      const cv::Point2f e01 = c[1] - c[0], e12 = c[2] - c[1];
      const double l01 = std::hypot(e01.x, e01.y), l12 = std::hypot(e12.x, e12.y);
      const cv::Point2f across = l01 <= l12 ? e01 : e12;
      const double shortPx = std::min(l01, l12);

      Grasp g;
      g.u = box.center.x, g.v = box.center.y;
      // The depth at the centre if the object is there, else the object's median depth.
      std::nth_element(obj.depths.begin(), obj.depths.begin() + static_cast<long>(obj.depths.size() / 2), obj.depths.end());
      const double median = obj.depths[obj.depths.size() / 2];
      const int ui = static_cast<int>(std::lround(g.u)), vi = static_cast<int>(std::lround(g.v));
      const bool onObject = ui >= 0 && vi >= 0 && ui < labels.cols && vi < labels.rows && labels.at<int>(vi, ui) == l;
      g.depthMm = onObject ? depthNear(f.zMm, g.u, g.v) : 0;
      if (!(g.depthMm > 0)) g.depthMm = median;
      const double clearPx = o_.gripper.clearanceMm * f.camera.fx / g.depthMm;
      g.widthPx = shortPx + 2 * clearPx;
      g.widthMm = g.widthPx * g.depthMm / f.camera.fx;
      if (g.widthMm > o_.gripper.maxOpeningMm) continue;
      g.jawPx = o_.gripper.jawLengthMm * f.camera.fx / g.depthMm;
      double ang = std::atan2(-across.y, across.x) / kDeg;
      while (ang <= -90) ang += 180;
      while (ang > 90) ang -= 180;
      g.angleDeg = ang;
      g.quality = 1;
      const auto pc = backProject(f.camera, g.u, g.v, g.depthMm);
      g.heightMm = floor->nx * pc.x + floor->ny * pc.y + floor->nz * pc.z - floor->offset;
      found.push_back({g, obj.top});
    }
    std::stable_sort(found.begin(), found.end(), [](const Candidate& a, const Candidate& b) { return a.top > b.top; });
    std::vector<Grasp> out;
    for (const auto& c : found) {
      if (static_cast<int>(out.size()) >= o_.maxGrasps) break;
      out.push_back(c.g);
    }
    return out;
  }

 private:
  GraspDetectorOptions o_;
};

}  // namespace

Result<std::unique_ptr<GraspDetector>> makeAnalyticDetector(const GraspDetectorOptions& o) {
  return std::unique_ptr<GraspDetector>(std::make_unique<AnalyticDetector>(o));
}

}  // namespace vgr::vision::grasp
