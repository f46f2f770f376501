#include "sim/locate_scenes.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include "core/angles.hpp"

namespace vgr::sim {

SceneRenderer makeRenderer(int width, int height, double fPx, double heightMm, double noiseSigma, std::uint64_t seed) {
  vision::PinholePlaneModel model(fPx, fPx, (width - 1) / 2.0, (height - 1) / 2.0,
                                  vision::PinholePlaneModel::downLookingCamera(0, 0, heightMm, 0), 0.0);
  SceneOptions o;
  o.width = width;
  o.height = height;
  o.noiseSigma = noiseSigma;
  o.seed = seed;
  return SceneRenderer(model, o);
}

SceneTruth truthAt(const SceneRenderer& r, double u, double v, double angleImgDeg) {
  SceneTruth t;
  const auto onPlane = r.model().pixelToPlane({u, v}, 0.0);
  t.xMm = onPlane ? onPlane->x : 0;
  t.yMm = onPlane ? onPlane->y : 0;
  t.zMm = r.model().planeZ();
  // The image angle of base rz: project a point along +x and measure; invert by one probe
  // (the down-looking camera maps rz to +-rz + const).
  auto imgAngle = [&](double rz) {
    const double a = rz * std::numbers::pi / 180;
    const auto c = r.model().project({t.xMm, t.yMm, t.zMm});
    const auto tip = r.model().project({t.xMm + 10 * std::cos(a), t.yMm + 10 * std::sin(a), t.zMm});
    return std::atan2(-(tip->v - c->v), tip->u - c->u) * 180 / std::numbers::pi;
  };
  const double a0 = imgAngle(0), a90 = imgAngle(90);
  const double sense = normaliseDeg(a90 - a0) > 0 ? 1.0 : -1.0;
  t.rzDeg = normaliseDeg(sense * (angleImgDeg - a0));
  const auto px = r.model().project({t.xMm, t.yMm, t.zMm});
  t.uPx = px->u;
  t.vPx = px->v;
  t.angleImgDeg = normaliseDeg(imgAngle(t.rzDeg));
  return t;
}

vision::PixelPoint drawnCentroid(const SceneRenderer& r, const SceneTruth& t) {
  SceneOptions o = r.options();
  o.noiseSigma = 0;
  const SceneRenderer clean(r.model(), o);
  cv::Mat img;
  clean.renderTruth(t, 0, img);
  double m = 0, mx = 0, my = 0;
  for (int y = 0; y < img.rows; ++y) {
    const auto* row = img.ptr<std::uint8_t>(y);
    for (int x = 0; x < img.cols; ++x) {
      const double bg = o.background + (8 * x) / img.cols;  // SceneRenderer's belt shading
      const double c = (row[x] - bg) / (o.foreground - bg);
      if (c <= 0) continue;
      m += c, mx += c * x, my += c * y;
    }
  }
  return {mx / m, my / m};
}

SceneTemplate makeSceneTemplate(const SceneRenderer& r, double angleImgDeg, int marginPx, std::uint64_t noiseSeed) {
  SceneTemplate tp;
  const auto& o = r.options();
  tp.truth = truthAt(r, (o.width - 1) / 2.0, (o.height - 1) / 2.0, angleImgDeg);
  cv::Mat full;
  r.renderTruth(tp.truth, noiseSeed, full);
  // Bounding box of the outline in the image.
  double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
  const double c = std::cos(tp.truth.rzDeg * std::numbers::pi / 180),
               s = std::sin(tp.truth.rzDeg * std::numbers::pi / 180);
  for (const auto& p : SceneRenderer::partOutlineMm()) {
    const auto px =
        r.model().project({tp.truth.xMm + c * p.x - s * p.y, tp.truth.yMm + s * p.x + c * p.y, tp.truth.zMm});
    x0 = std::min(x0, px->u), x1 = std::max(x1, px->u), y0 = std::min(y0, px->v), y1 = std::max(y1, px->v);
  }
  const cv::Rect box =
      cv::Rect(static_cast<int>(std::floor(x0)) - marginPx, static_cast<int>(std::floor(y0)) - marginPx,
               static_cast<int>(std::ceil(x1 - x0)) + 2 * marginPx + 1,
               static_cast<int>(std::ceil(y1 - y0)) + 2 * marginPx + 1) &
      cv::Rect(0, 0, full.cols, full.rows);
  tp.image = full(box).clone();
  tp.grasp = {tp.truth.uPx - box.x, tp.truth.vPx - box.y};
  const auto drawn = drawnCentroid(r, tp.truth);
  tp.graspDrawn = {drawn.u - box.x, drawn.v - box.y};
  return tp;
}

}  // namespace vgr::sim
