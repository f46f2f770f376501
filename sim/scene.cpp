#include "sim/scene.hpp"

#include <cmath>
#include <random>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "config/cell_config.hpp"
#include "core/angles.hpp"

namespace vgr::sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

std::vector<PointMm> makeOutline() {
  // A 100 x 50 mm plate with a pointed end: elongated (a well-defined major axis) and
  // asymmetric along it (the third-order moment tells the ends apart).
  std::vector<PointMm> p = {{-50, -25}, {30, -25}, {50, 0}, {30, 25}, {-50, 25}};
  // Shift so that the area centroid is the origin (shoelace formula).
  double a = 0, cx = 0, cy = 0;
  for (std::size_t i = 0; i < p.size(); ++i) {
    const PointMm& q = p[i];
    const PointMm& r = p[(i + 1) % p.size()];
    const double cr = q.x * r.y - r.x * q.y;
    a += cr;
    cx += (q.x + r.x) * cr;
    cy += (q.y + r.y) * cr;
  }
  a *= 0.5;
  cx /= 6 * a;
  cy /= 6 * a;
  for (auto& q : p) q.x -= cx, q.y -= cy;
  return p;
}

// Fills the polygon `img` (px) with `gray`, anti-aliased: drawn at kScale x resolution
// around it, then area-averaged, blended over what dst holds.
void fillPolygonAntiAliased(const std::vector<cv::Point2f>& img, std::uint8_t gray, cv::Mat& dst) {
  if (img.size() < 3) return;
  constexpr int kScale = 8;
  constexpr int kShift = 4;  // fractional bits for fillPoly
  cv::Rect box = cv::boundingRect(img);
  box = (box + cv::Size(8, 8) - cv::Point(4, 4)) & cv::Rect(0, 0, dst.cols, dst.rows);
  if (box.empty()) return;
  cv::Mat hi(box.height * kScale, box.width * kScale, CV_8UC1, cv::Scalar(0));
  std::vector<cv::Point> poly;
  for (const auto& p : img) {
    // Original pixel i covers [i - 0.5, i + 0.5]; high-res pixel k has its centre at
    // (k + 0.5) / kScale - 0.5 in original pixels.
    const double hx = ((double{p.x} - box.x) + 0.5) * kScale - 0.5;
    const double hy = ((double{p.y} - box.y) + 0.5) * kScale - 0.5;
    poly.emplace_back(cvRound(hx * (1 << kShift)), cvRound(hy * (1 << kShift)));
  }
  cv::fillPoly(hi, std::vector<std::vector<cv::Point>>{poly}, cv::Scalar(255), cv::LINE_8, kShift);
  cv::Mat cover;
  cv::resize(hi, cover, box.size(), 0, 0, cv::INTER_AREA);
  cv::Mat roi = dst(box);
  for (int y = 0; y < roi.rows; ++y) {
    auto* r = roi.ptr<std::uint8_t>(y);
    const auto* cv8 = cover.ptr<std::uint8_t>(y);
    for (int x = 0; x < roi.cols; ++x) {
      const double a = cv8[x] / 255.0;
      r[x] = static_cast<std::uint8_t>(std::lround(r[x] * (1 - a) + gray * a));
    }
  }
}

}  // namespace

SceneRenderer::SceneRenderer(const vision::PinholePlaneModel& model, SceneOptions options)
    : model_(model), options_(options), placement_(model) {}

SceneRenderer::SceneRenderer(const vision::PinholePlaneModel& model, SceneOptions options,
                             const vision::PinholePlaneModel& placement)
    : model_(model), options_(options), placement_(placement) {}

SceneRenderer SceneRenderer::fromCellConfig(const config::CellConfig& c) {
  const auto& m = c.model;
  // The rendered camera is where `model` says, moved by sim.camera_shift (a knocked camera
  // the calibration does not know about).
  vision::PinholePlaneModel model(m.fx, m.fy, m.cx, m.cy,
                                  vision::PinholePlaneModel::downLookingCamera(m.camX + c.sim.shiftXMm, m.camY + c.sim.shiftYMm,
                                                                               m.camZ + c.sim.shiftZMm,
                                                                               m.camRzDeg + c.sim.shiftRzDeg),
                                  m.planeZ);
  const vision::PinholePlaneModel nominal(m.fx, m.fy, m.cx, m.cy,
                                          vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg),
                                          m.planeZ);
  SceneOptions o;
  o.stillFrame = c.sim.still ? 1 : 0;
  o.fiducialXMm = c.sim.fiducialXMm;
  o.fiducialYMm = c.sim.fiducialYMm;
  o.fiducialDiameterMm = c.sim.fiducialDiameterMm;
  o.width = c.sim.width;
  o.height = c.sim.height;
  o.noiseSigma = c.sim.noiseSigma;
  o.seed = c.sim.seed;
  return SceneRenderer(model, o, nominal);
}

const std::vector<PointMm>& SceneRenderer::partOutlineMm() {
  static const std::vector<PointMm> outline = makeOutline();
  return outline;
}

SceneTruth SceneRenderer::truthForFrame(std::uint64_t frameId) const {
  // splitmix-style seeding: neighbouring frame ids give unrelated poses.
  const std::uint64_t poseId = options_.stillFrame > 0 ? options_.stillFrame : frameId;
  std::mt19937_64 rng(options_.seed * 0x9E3779B97F4A7C15ull + poseId * 0xBF58476D1CE4E5B9ull + 1);
  std::uniform_real_distribution<double> du(options_.marginPx, options_.width - 1 - options_.marginPx);
  std::uniform_real_distribution<double> dv(options_.marginPx, options_.height - 1 - options_.marginPx);
  std::uniform_real_distribution<double> da(-180.0, 180.0);
  const double u = du(rng), v = dv(rng), rz = normaliseDeg(da(rng));
  const auto onPlane = placement_.pixelToPlane({u, v}, 0.0);

  SceneTruth t;
  t.frameId = frameId;
  t.xMm = onPlane ? onPlane->x : 0;
  t.yMm = onPlane ? onPlane->y : 0;
  t.zMm = model_.planeZ();
  t.rzDeg = rz;
  const auto px = model_.project({t.xMm, t.yMm, t.zMm});
  t.uPx = px ? px->u : u;
  t.vPx = px ? px->v : v;
  // Image direction of the part's +x axis: project a point 10 mm along it.
  const auto tip = model_.project({t.xMm + 10 * std::cos(rz * kDegToRad), t.yMm + 10 * std::sin(rz * kDegToRad), t.zMm});
  if (tip) t.angleImgDeg = normaliseDeg(std::atan2(-(tip->v - t.vPx), tip->u - t.uPx) / kDegToRad);
  return t;
}

void SceneRenderer::renderTruth(const SceneTruth& t, std::uint64_t noiseSeed, cv::Mat& dst) const {
  dst.create(options_.height, options_.width, CV_8UC1);
  // Conveyor: dark with a gentle left-to-right shading, like a real belt under a bar light.
  for (int y = 0; y < dst.rows; ++y) {
    auto* row = dst.ptr<std::uint8_t>(y);
    for (int x = 0; x < dst.cols; ++x) row[x] = static_cast<std::uint8_t>(options_.background + (8 * x) / dst.cols);
  }

  // The fiducial first (the part may lie on it), then the part. Polygons on the plane
  // project exactly (lines stay lines); the disk is a 96-gon.
  if (options_.fiducialDiameterMm > 0) {
    std::vector<cv::Point2f> disk;
    const double r = options_.fiducialDiameterMm / 2;
    for (int k = 0; k < 96; ++k) {
      const double a = 2 * M_PI * k / 96;
      const auto px = model_.project({options_.fiducialXMm + r * std::cos(a), options_.fiducialYMm + r * std::sin(a), model_.planeZ()});
      if (px) disk.emplace_back(static_cast<float>(px->u), static_cast<float>(px->v));
    }
    fillPolygonAntiAliased(disk, options_.fiducialGray, dst);
  }
  const double c = std::cos(t.rzDeg * kDegToRad), s = std::sin(t.rzDeg * kDegToRad);
  std::vector<cv::Point2f> img;
  for (const auto& p : partOutlineMm()) {
    const auto px = model_.project({t.xMm + c * p.x - s * p.y, t.yMm + s * p.x + c * p.y, t.zMm});
    if (px) img.emplace_back(static_cast<float>(px->u), static_cast<float>(px->v));
  }
  fillPolygonAntiAliased(img, options_.foreground, dst);

  if (options_.noiseSigma > 0) {
    cv::Mat noise(dst.size(), CV_16SC1);
    cv::RNG rng(noiseSeed * 0x2545F4914F6CDD1Dull + 7);
    rng.fill(noise, cv::RNG::NORMAL, 0, options_.noiseSigma);
    cv::Mat sum;
    dst.convertTo(sum, CV_16SC1);
    sum += noise;
    sum.convertTo(dst, CV_8UC1);  // saturates
  }
}

SceneTruth SceneRenderer::render(std::uint64_t frameId, cv::Mat& dst) const {
  SceneTruth t = truthForFrame(frameId);
  t.frameId = frameId;
  renderTruth(t, options_.seed ^ (frameId << 20), dst);
  return t;
}

SceneTruth SceneRenderer::render16(std::uint64_t frameId, cv::Mat& dst, cv::Mat& scratch) const {
  const SceneTruth t = render(frameId, scratch);
  scratch.convertTo(dst, CV_16UC1, 257.0);
  return t;
}

}  // namespace vgr::sim
