#include "sim/part_scene.hpp"

#include <algorithm>
#include <cmath>
#include <random>
#include <stdexcept>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "config/cell_config.hpp"
#include "core/angles.hpp"

namespace vgr::sim {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

Polygon rect(double x0, double y0, double x1, double y1) { return {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}}; }

Polygon circle(double cx, double cy, double r, int n = 32) {
  Polygon p;
  for (int i = 0; i < n; ++i) {
    const double a = 2 * M_PI * i / n;
    p.push_back({cx + r * std::cos(a), cy + r * std::sin(a)});
  }
  return p;
}

double radiusOf(const PartModel& m) {
  double r = 0;
  for (const auto& l : m.layers)
    for (const auto& q : l.outline) r = std::max(r, std::hypot(q.x, q.y));
  return r;
}

}  // namespace

// ---- part models ----------------------------------------------------------------------

PartModel PartModel::flat() {
  PartModel m;
  m.name = "flat";
  PartLayer plate;
  plate.outline = SceneRenderer::partOutlineMm();
  plate.baseMm = plate.topMm = 0;
  plate.gray = 200;
  // The outline's centroid sits near (-3.5, 0); features are placed relative to that frame.
  plate.holes = {circle(-32, 10, 5), circle(-32, -12, 3)};
  plate.marks = {
      // an "L", a triangle, four bars of a code and a cross: corners for ORB/SIFT
      {{-18, -20}, {-10, -20}, {-10, -17.5}, {-15.5, -17.5}, {-15.5, -9}, {-18, -9}},
      {{14, 8}, {26, 14}, {14, 18}},
      rect(-4, 6, -2.5, 18), rect(-1, 6, 0, 18), rect(1.5, 6, 4, 18), rect(5.5, 6, 6.5, 18),
      rect(6, -18, 16, -15.5), rect(9.75, -22, 12.25, -11.5),
  };
  m.layers = {plate};
  m.grasp = {20, 0};
  m.graspHeightMm = 0;
  m.radiusMm = radiusOf(m);
  return m;
}

PartModel PartModel::multi(int levels) {
  levels = std::clamp(levels, 2, 4);
  PartModel m;
  m.name = "multi";
  PartLayer base;
  base.outline = {{-65, -45}, {50, -45}, {65, -30}, {65, 45}, {-40, 45}, {-65, 20}};
  base.baseMm = 0;
  base.topMm = 8;
  base.gray = 150;
  base.holes = {circle(-55, -8, 5), circle(54, 34, 4)};
  base.marks = {
      {{-60, -40}, {-50, -40}, {-50, -37}, {-57, -37}, {-57, -30}, {-60, -30}},  // L
      {{38, -40}, {50, -40}, {38, -31}},                                       // triangle
      rect(-15, 26, -13, 39), rect(-11, 26, -10, 39), rect(-8, 26, -5, 39), rect(-3, 26, -2, 39),  // bars
      rect(0, -41, 12, -38), rect(4.5, -44, 7.5, -34),                           // cross
      rect(48, -5, 58, -2), rect(52, 5, 60, 12),                                 // two tags
  };
  m.layers.push_back(base);

  PartLayer rib;
  rib.outline = rect(-45, -27, 15, -14);
  rib.baseMm = 8;
  rib.topMm = 20;
  rib.gray = 190;
  rib.marks = {rect(-38, -23, -33, -18), {{0, -24}, {8, -24}, {0, -17}}};
  m.layers.push_back(rib);
  m.grasp = {-15, -20.5};
  m.graspHeightMm = 20;

  if (levels >= 3) {
    PartLayer boss;
    boss.outline = circle(30, 12, 15, 48);
    boss.baseMm = 8;
    boss.topMm = 35;
    boss.gray = 220;
    boss.marks = {circle(30, 12, 5, 32), rect(37, 11, 43, 13.5)};  // a blind hole and a key mark
    m.layers.push_back(boss);
    m.grasp = {30, 12};
    m.graspHeightMm = 35;
  }
  if (levels >= 4) {
    PartLayer block;
    block.outline = rect(-46, 2, -24, 24);
    block.baseMm = 8;
    block.topMm = 50;
    block.gray = 175;
    block.marks = {{{-42, 6}, {-32, 6}, {-42, 16}}};
    m.layers.push_back(block);
  }
  std::sort(m.layers.begin(), m.layers.end(), [](const PartLayer& a, const PartLayer& b) { return a.topMm < b.topMm; });
  m.radiusMm = radiusOf(m);
  return m;
}

namespace {

PartModel plate8(const std::string& name, Polygon outline, std::vector<Polygon> holes = {}) {
  PartModel m;
  m.name = name;
  PartLayer l;
  l.outline = std::move(outline);
  l.holes = std::move(holes);
  l.baseMm = 0;
  l.topMm = 8;
  l.gray = 190;
  m.layers = {l};
  m.grasp = {0, 0};
  m.graspHeightMm = 8;
  m.radiusMm = radiusOf(m);
  return m;
}

}  // namespace

const std::vector<std::string>& PartModel::classNames() {
  static const std::vector<std::string> names = {"flat", "disc", "ring", "hex", "square", "square_small", "rect", "rect_notch"};
  return names;
}

Result<PartModel> PartModel::byName(const std::string& name) {
  if (name == "flat") return flat();
  if (name == "disc") return plate8(name, circle(0, 0, 40, 96));
  if (name == "ring") return plate8(name, circle(0, 0, 40, 96), {circle(0, 0, 15, 48)});
  if (name == "hex") return plate8(name, circle(0, 0, 40, 6));
  if (name == "square") return plate8(name, rect(-35, -35, 35, 35));
  if (name == "square_small") return plate8(name, rect(-30, -30, 30, 30));
  if (name == "rect") return plate8(name, rect(-50, -25, 50, 25));
  if (name == "rect_notch")
    return plate8(name, {{-50, -25}, {50, -25}, {50, 25}, {10, 25}, {10, 10}, {-10, 10}, {-10, 25}, {-50, 25}});
  std::string all;
  for (const auto& n : classNames()) {
    if (!all.empty()) all += ", ";
    all += n;
  }
  return fail(Status::BadArgument, "unknown part class '" + name + "' (expected one of " + all + ")");
}

// ---- renderer -------------------------------------------------------------------------

// A layer's top face drawn in part coordinates at `scale` px/mm over [-half, half]^2 mm:
// sheet pixel (i, j) has its centre at x = (i + 0.5) / scale - half, y = half - (j + 0.5) / scale
// (y up, as the part is seen from above). `tex` is the face's gray level with its marks,
// holes and a machined grain; `mask` is its coverage (255 inside, anti-aliased edges).
struct PartSceneRenderer::Sheet {
  cv::Mat tex, mask;
  double scale = 4, half = 80;
};

namespace {

std::vector<cv::Point> toSheet(const Polygon& poly, double scale, double half) {
  constexpr int kShift = 4;
  std::vector<cv::Point> out;
  for (const auto& q : poly) {
    const double i = (q.x + half) * scale - 0.5, j = (half - q.y) * scale - 0.5;
    out.emplace_back(cvRound(i * (1 << kShift)), cvRound(j * (1 << kShift)));
  }
  return out;
}

}  // namespace

PartSceneRenderer::PartSceneRenderer(PartModel part, PartSceneOptions options)
    : part_(std::move(part)),
      options_(options),
      focal_(options.focalPx > 0 ? options.focalPx : 1000.0 * options.width / 1280.0),
      camera_(focal_, focal_, options.cxPx >= 0 ? options.cxPx : (options.width - 1) / 2.0,
              options.cyPx >= 0 ? options.cyPx : (options.height - 1) / 2.0,
              vision::PinholePlaneModel::downLookingCamera(options.cameraXMm + options.shiftXMm, options.cameraYMm + options.shiftYMm,
                                                          options.cameraHeightMm + options.shiftZMm,
                                                          options.cameraRzDeg + options.shiftRzDeg),
              0.0),
      placement_(focal_, focal_, options.cxPx >= 0 ? options.cxPx : (options.width - 1) / 2.0,
                 options.cyPx >= 0 ? options.cyPx : (options.height - 1) / 2.0,
                 vision::PinholePlaneModel::downLookingCamera(options.cameraXMm, options.cameraYMm, options.cameraHeightMm,
                                                             options.cameraRzDeg),
                 0.0) {
  sheets_ = makeSheets(part_);
}

PartSceneRenderer::PartSceneRenderer(std::vector<PartModel> classes, PartSceneOptions options)
    : PartSceneRenderer(classes.at(0), options) {
  for (std::size_t c = 1; c < classes.size(); ++c) {
    Sheets sh = makeSheets(classes[c]);
    extra_.emplace_back(std::move(classes[c]), std::move(sh));
  }
}

const PartModel& PartSceneRenderer::model(int c) const { return c <= 0 ? part_ : extra_.at(c - 1).first; }
const PartSceneRenderer::Sheets& PartSceneRenderer::sheetsOf(int c) const { return c <= 0 ? sheets_ : extra_.at(c - 1).second; }

std::vector<const PartModel*> PartSceneRenderer::classes() const {
  std::vector<const PartModel*> out{&part_};
  for (const auto& e : extra_) out.push_back(&e.first);
  return out;
}

PartSceneRenderer::Sheets PartSceneRenderer::makeSheets(const PartModel& part) const {
  Sheets sheets;
  double top = 0;
  for (const auto& l : part.layers) top = std::max(top, l.topMm);
  const double pxPerMm = focal_ / std::max(1.0, options_.cameraHeightMm - top);
  for (std::size_t k = 0; k < part.layers.size(); ++k) {
    const PartLayer& layer = part.layers[k];
    auto sheet = std::make_shared<Sheet>();
    sheet->scale = std::max(4.0, std::ceil(2 * pxPerMm));
    sheet->half = part.radiusMm + 4;
    const int n = static_cast<int>(std::ceil(2 * sheet->half * sheet->scale));
    // Machined grain: fixed speckle (unique per place, so features are distinctive) plus
    // faint fly-cut arcs, both fixed to the part.
    cv::Mat speckle(n, n, CV_32FC1);
    cv::RNG rng(0x5EED + k);
    rng.fill(speckle, cv::RNG::NORMAL, 0, 10);
    cv::GaussianBlur(speckle, speckle, cv::Size(), 0.6 * sheet->scale);
    cv::Mat tex(n, n, CV_32FC1);
    for (int j = 0; j < n; ++j) {
      auto* row = tex.ptr<float>(j);
      const auto* sp = speckle.ptr<float>(j);
      for (int i = 0; i < n; ++i) {
        const double x = (i + 0.5) / sheet->scale - sheet->half, y = sheet->half - (j + 0.5) / sheet->scale;
        const double arc = std::sin(2 * M_PI * std::hypot(x + 160, y - 40) / 1.6);
        row[i] = options_.plainFaces ? static_cast<float>(layer.gray) : static_cast<float>(layer.gray + 3 * arc + sp[i]);
      }
    }
    tex.convertTo(sheet->tex, CV_8UC1);
    std::vector<std::vector<cv::Point>> marks, holes;
    if (!options_.plainFaces)
      for (const auto& p : layer.marks) marks.push_back(toSheet(p, sheet->scale, sheet->half));
    for (const auto& p : layer.holes) holes.push_back(toSheet(p, sheet->scale, sheet->half));
    if (!marks.empty()) cv::fillPoly(sheet->tex, marks, cv::Scalar(std::max(0, layer.gray - 110)), cv::LINE_AA, 4);
    if (!holes.empty()) cv::fillPoly(sheet->tex, holes, cv::Scalar(options_.background), cv::LINE_AA, 4);
    sheet->mask = cv::Mat::zeros(n, n, CV_8UC1);
    cv::fillPoly(sheet->mask, std::vector<std::vector<cv::Point>>{toSheet(layer.outline, sheet->scale, sheet->half)},
                 cv::Scalar(255), cv::LINE_AA, 4);
    sheets.push_back(std::move(sheet));
  }
  return sheets;
}

PartSceneRenderer PartSceneRenderer::fromCellConfig(const config::CellConfig& c) {
  const auto& m = c.model;
  PartSceneOptions o;
  o.width = c.sim.width;
  o.height = c.sim.height;
  o.focalPx = m.fx;
  o.cxPx = m.cx;
  o.cyPx = m.cy;
  o.cameraXMm = m.camX;
  o.cameraYMm = m.camY;
  o.cameraHeightMm = m.camZ - m.planeZ;
  o.cameraRzDeg = m.camRzDeg;
  o.angleRangeDeg = c.sim.angleRangeDeg;
  o.partsPerImage = c.sim.parts;
  o.clutter = c.sim.clutter;
  o.noiseSigma = c.sim.noiseSigma;
  o.seed = c.sim.seed;
  o.shiftXMm = c.sim.shiftXMm;
  o.shiftYMm = c.sim.shiftYMm;
  o.shiftZMm = c.sim.shiftZMm;
  o.shiftRzDeg = c.sim.shiftRzDeg;
  o.fiducialXMm = c.sim.fiducialXMm;
  o.fiducialYMm = c.sim.fiducialYMm;
  o.fiducialDiameterMm = c.sim.fiducialDiameterMm;
  if (!c.sim.classes.empty()) {
    std::vector<PartModel> models;
    for (const auto& name : c.sim.classes) {
      auto model = PartModel::byName(name);
      if (!model) throw std::invalid_argument("sim.classes: " + model.error().message);
      models.push_back(std::move(*model));
    }
    return PartSceneRenderer(std::move(models), o);
  }
  return PartSceneRenderer(c.sim.scene == "multi" ? PartModel::multi(c.sim.levels) : PartModel::flat(), o);
}

PlacedPart PartSceneRenderer::place(double xMm, double yMm, double rzDeg, int classIndex) const {
  PlacedPart p;
  p.classIndex = classIndex;
  p.xMm = xMm;
  p.yMm = yMm;
  p.rzDeg = normaliseDeg(rzDeg);
  const double c = std::cos(p.rzDeg * kDegToRad), s = std::sin(p.rzDeg * kDegToRad);
  const auto& g = model(classIndex).grasp;
  const double h = model(classIndex).graspHeightMm;
  const auto px = camera_.project({xMm + c * g.x - s * g.y, yMm + s * g.x + c * g.y, h});
  // The image direction of the part's +x axis at the grasp height, minus the template's
  // (rz = 0 under the optical axis): the rotation as displayed.
  const auto tip = camera_.project({xMm + c * (g.x + 10) - s * g.y, yMm + s * (g.x + 10) + c * g.y, h});
  const double x0 = options_.cameraXMm, y0 = options_.cameraYMm;
  const auto t0 = camera_.project({x0 + g.x, y0 + g.y, h});
  const auto t1 = camera_.project({x0 + g.x + 10, y0 + g.y, h});
  if (px && tip && t0 && t1) {
    p.uPx = px->u;
    p.vPx = px->v;
    const double a = std::atan2(-(tip->v - px->v), tip->u - px->u);
    const double a0 = std::atan2(-(t1->v - t0->v), t1->u - t0->u);
    p.angleDeg = normaliseDeg((a - a0) / kDegToRad);
  }
  return p;
}

namespace {

// Warps `src` (CV_8UC1) by the homography taking the four `from` points to `to` into dst
// (CV_8UC1), alpha-blended by `mask` warped the same way (a face's texture onto the image).
void blendWarped(const cv::Mat& src, const cv::Mat& mask, const std::vector<cv::Point2f>& from,
                 const std::vector<cv::Point2f>& to, cv::Mat& dst) {
  const cv::Rect box = cv::boundingRect(to) & cv::Rect(0, 0, dst.cols, dst.rows);
  if (box.empty()) return;
  const cv::Mat h = (cv::Mat_<double>(3, 3) << 1, 0, -box.x, 0, 1, -box.y, 0, 0, 1) * cv::getPerspectiveTransform(from, to);
  cv::Mat tex, alpha;
  cv::warpPerspective(src, tex, h, box.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::warpPerspective(mask, alpha, h, box.size(), cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
  cv::Mat roi = dst(box);
  for (int y = 0; y < roi.rows; ++y) {
    auto* r = roi.ptr<std::uint8_t>(y);
    const auto* t = tex.ptr<std::uint8_t>(y);
    const auto* m = alpha.ptr<std::uint8_t>(y);
    for (int x = 0; x < roi.cols; ++x)
      if (m[x]) r[x] = static_cast<std::uint8_t>((r[x] * (255 - m[x]) + t[x] * m[x] + 127) / 255);
  }
}

// Image px of a part-frame point at height h for a part placed at p.
cv::Point2d projectPart(const vision::PinholePlaneModel& cam, const PlacedPart& p, PointMm q, double h) {
  const double c = std::cos(p.rzDeg * kDegToRad), s = std::sin(p.rzDeg * kDegToRad);
  const auto px = cam.project({p.xMm + c * q.x - s * q.y, p.yMm + s * q.x + c * q.y, h});
  return px ? cv::Point2d(px->u, px->v) : cv::Point2d(-1e6, -1e6);
}

cv::Rect2d footprint(const vision::PinholePlaneModel& cam, const PartModel& m, const PlacedPart& p) {
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (const auto& l : m.layers)
    for (double h : {l.baseMm, l.topMm})
      for (const auto& q : l.outline) {
        const cv::Point2d a = projectPart(cam, p, q, h);
        x0 = std::min(x0, a.x), y0 = std::min(y0, a.y), x1 = std::max(x1, a.x), y1 = std::max(y1, a.y);
      }
  return {x0, y0, x1 - x0, y1 - y0};
}

}  // namespace

PartScene PartSceneRenderer::sample(std::uint64_t index) const {
  PartScene scene;
  scene.index = index;
  std::mt19937_64 rng(options_.seed * 0x9E3779B97F4A7C15ull + index * 0xBF58476D1CE4E5B9ull + 11);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  if (unit(rng) < options_.emptyRatio) return scene;
  const double range = std::clamp(options_.angleRangeDeg, 0.0, 180.0);
  std::vector<cv::Rect2d> taken;
  const cv::Rect2d image(options_.marginPx, options_.marginPx, options_.width - 1 - 2.0 * options_.marginPx,
                         options_.height - 1 - 2.0 * options_.marginPx);
  // The class of each part from an RNG of its own, so one class samples exactly as before.
  std::mt19937_64 classRng(options_.seed * 0x94D049BB133111EBull + index * 0x9E3779B97F4A7C15ull + 23);
  const int classCount = 1 + static_cast<int>(extra_.size());
  for (int k = 0; k < options_.partsPerImage; ++k) {
    const int cls = classCount > 1 ? static_cast<int>(classRng() % static_cast<std::uint64_t>(classCount)) : 0;
    for (int attempt = 0; attempt < 400; ++attempt) {
      const double u = unit(rng) * (options_.width - 1), v = unit(rng) * (options_.height - 1);
      const double rz = (2 * unit(rng) - 1) * range;
      const auto onPlane = placement_.pixelToPlane({u, v}, 0.0);
      if (!onPlane) continue;
      const PlacedPart p = place(onPlane->x, onPlane->y, rz, cls);
      const cv::Rect2d box = footprint(placement_, model(cls), p);
      if ((box & image) != box) continue;
      const cv::Rect2d grown(box.x - 6, box.y - 6, box.width + 12, box.height + 12);
      if (std::any_of(taken.begin(), taken.end(), [&](const cv::Rect2d& r) { return (r & grown).area() > 0; })) continue;
      taken.push_back(grown);
      scene.parts.push_back(p);
      break;
    }
  }
  return scene;
}

void PartSceneRenderer::drawPart(const PlacedPart& p, cv::Mat& dst) const {
  const PartModel& part = model(p.classIndex);
  const Sheets& sheets = sheetsOf(p.classIndex);
  for (std::size_t k = 0; k < part.layers.size(); ++k) {
    const PartLayer& layer = part.layers[k];
    const Sheet& sheet = *sheets[k];
    // Walls: each outline edge is a vertical quad from baseMm to topMm; only those facing
    // away from the optical axis stay visible once the top face is drawn over them.
    if (layer.topMm > layer.baseMm) {
      const double c = std::cos(p.rzDeg * kDegToRad), s = std::sin(p.rzDeg * kDegToRad);
      for (std::size_t i = 0; i < layer.outline.size(); ++i) {
        const PointMm a = layer.outline[i], b = layer.outline[(i + 1) % layer.outline.size()];
        // Lambert-ish shade from the edge's outward normal in the base frame (light from +x+y).
        const double nx = (b.y - a.y), ny = -(b.x - a.x), nl = std::hypot(nx, ny);
        const double bx = (c * nx - s * ny) / nl, by = (s * nx + c * ny) / nl;
        const int gray = static_cast<int>(85 + 45 * (0.5 + 0.5 * (bx * 0.6 + by * 0.8)));
        constexpr int kShift = 4;
        std::vector<cv::Point> quad;
        for (const cv::Point2d q : {projectPart(camera_, p, a, layer.baseMm), projectPart(camera_, p, b, layer.baseMm),
                                    projectPart(camera_, p, b, layer.topMm), projectPart(camera_, p, a, layer.topMm)})
          quad.emplace_back(cvRound(q.x * (1 << kShift)), cvRound(q.y * (1 << kShift)));
        cv::fillConvexPoly(dst, quad, cv::Scalar(gray), cv::LINE_AA, kShift);
      }
    }
    // Top face: the plane z = topMm maps to the image by a homography; warp the sheet with it.
    const int n = sheet.tex.cols;
    std::vector<cv::Point2f> from, to;
    for (const auto& [i, j] : {std::pair{0, 0}, std::pair{n - 1, 0}, std::pair{n - 1, n - 1}, std::pair{0, n - 1}}) {
      const PointMm q{(i + 0.5) / sheet.scale - sheet.half, sheet.half - (j + 0.5) / sheet.scale};
      const cv::Point2d a = projectPart(camera_, p, q, layer.topMm);
      from.emplace_back(static_cast<float>(i), static_cast<float>(j));
      to.emplace_back(static_cast<float>(a.x), static_cast<float>(a.y));
    }
    blendWarped(sheet.tex, sheet.mask, from, to, dst);
  }
}

void PartSceneRenderer::drawDecoys(const PartScene& scene, cv::Mat& dst) const {
  // An RNG of its own, so that datasets without decoys render exactly as before.
  std::mt19937_64 rng(options_.seed * 0x9FB21C651E98DF25ull + scene.index * 0xC2B2AE3D27D4EB4Full + 17);
  std::uniform_real_distribution<double> unit(0.0, 1.0);
  std::vector<cv::Rect2d> taken;
  for (const auto& p : scene.parts) {
    const cv::Rect2d b = footprint(camera_, model(p.classIndex), p);
    taken.emplace_back(b.x - 6, b.y - 6, b.width + 12, b.height + 12);
  }
  // Source layers drawn in proportion to their top-face area (the base plate most often).
  std::vector<double> area;
  for (const auto& l : part_.layers) {
    std::vector<cv::Point2f> poly;
    for (const auto& q : l.outline) poly.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
    area.push_back(cv::contourArea(poly));
  }
  std::discrete_distribution<std::size_t> pickLayer(area.begin(), area.end());
  const cv::Rect2d image(0, 0, options_.width - 1, options_.height - 1);
  const int decoys = std::clamp(options_.decoys, 0, 16);
  for (int k = 0; k < decoys; ++k) {
    for (int attempt = 0; attempt < 100; ++attempt) {
      const std::size_t li = pickLayer(rng);
      const PartLayer& layer = part_.layers[li];
      const Sheet& sheet = *sheets_[li];
      // The piece: a convex polygon of 5-8 corners about a point of the face (part frame, mm).
      double x0 = 1e9, y0 = 1e9, x1 = -1e9, y1 = -1e9;
      std::vector<cv::Point2f> outline;
      for (const auto& q : layer.outline) {
        outline.emplace_back(static_cast<float>(q.x), static_cast<float>(q.y));
        x0 = std::min(x0, q.x), y0 = std::min(y0, q.y), x1 = std::max(x1, q.x), y1 = std::max(y1, q.y);
      }
      const PointMm c{x0 + unit(rng) * (x1 - x0), y0 + unit(rng) * (y1 - y0)};
      if (cv::pointPolygonTest(outline, cv::Point2f(static_cast<float>(c.x), static_cast<float>(c.y)), false) < 0) continue;
      const double r = (0.2 + 0.2 * unit(rng)) * part_.radiusMm;
      const int corners = 5 + static_cast<int>(unit(rng) * 4);
      const double a0 = unit(rng) * 2 * M_PI;
      Polygon piece;
      for (int i = 0; i < corners; ++i) {
        const double a = a0 + 2 * M_PI * (i + 0.3 * unit(rng)) / corners, rr = r * (0.6 + 0.4 * unit(rng));
        piece.push_back({c.x + rr * std::cos(a), c.y + rr * std::sin(a)});
      }
      // Lying flat: its top face at its own thickness, turned anywhere, its centre anywhere.
      const double top = std::max(0.0, layer.topMm - layer.baseMm);
      const auto at = camera_.pixelToPlane({unit(rng) * (options_.width - 1), unit(rng) * (options_.height - 1)}, top);
      if (!at) continue;
      PlacedPart pose;
      pose.rzDeg = (2 * unit(rng) - 1) * 180;
      const double cs = std::cos(pose.rzDeg * kDegToRad), sn = std::sin(pose.rzDeg * kDegToRad);
      pose.xMm = at->x - (cs * c.x - sn * c.y);
      pose.yMm = at->y - (sn * c.x + cs * c.y);
      double bx0 = 1e18, by0 = 1e18, bx1 = -1e18, by1 = -1e18;
      for (const auto& q : piece)
        for (double h : {0.0, top}) {
          const cv::Point2d a = projectPart(camera_, pose, q, h);
          bx0 = std::min(bx0, a.x), by0 = std::min(by0, a.y), bx1 = std::max(bx1, a.x), by1 = std::max(by1, a.y);
        }
      const cv::Rect2d box(bx0, by0, bx1 - bx0, by1 - by0);
      if ((box & image) != box) continue;
      if (std::any_of(taken.begin(), taken.end(), [&](const cv::Rect2d& t) { return (t & box).area() > 0; })) continue;
      taken.emplace_back(box.x - 4, box.y - 4, box.width + 8, box.height + 8);

      // The piece's cut edges as a dark wall (its outline on the belt, under the top face),
      // then its top: the face's own texture inside the piece, mapped like drawPart's faces.
      constexpr int kShift = 4;
      const std::vector<cv::Point> sheetPoly = toSheet(piece, sheet.scale, sheet.half);
      cv::Rect sub = cv::boundingRect(sheetPoly);
      sub = cv::Rect(sub.x / (1 << kShift) - 2, sub.y / (1 << kShift) - 2, sub.width / (1 << kShift) + 5,
                     sub.height / (1 << kShift) + 5) &
            cv::Rect(0, 0, sheet.tex.cols, sheet.tex.rows);
      if (sub.empty()) continue;
      cv::Mat pieceMask = cv::Mat::zeros(sheet.mask.size(), CV_8UC1);
      cv::fillPoly(pieceMask, std::vector<std::vector<cv::Point>>{sheetPoly}, cv::Scalar(255), cv::LINE_AA, kShift);
      cv::min(pieceMask(sub), sheet.mask(sub), pieceMask);
      const cv::Mat wall(sub.size(), CV_8UC1, cv::Scalar(95));
      for (const auto& [h, src] : {std::pair{0.0, wall}, std::pair{top, cv::Mat(sheet.tex(sub))}}) {
        std::vector<cv::Point2f> from, to;
        for (const auto& [i, j] : {std::pair{0, 0}, std::pair{sub.width - 1, 0}, std::pair{sub.width - 1, sub.height - 1},
                                   std::pair{0, sub.height - 1}}) {
          const PointMm q{(sub.x + i + 0.5) / sheet.scale - sheet.half, sheet.half - (sub.y + j + 0.5) / sheet.scale};
          const cv::Point2d a = projectPart(camera_, pose, q, h);
          from.emplace_back(static_cast<float>(i), static_cast<float>(j));
          to.emplace_back(static_cast<float>(a.x), static_cast<float>(a.y));
        }
        blendWarped(src, pieceMask, from, to, dst);
      }
      break;
    }
  }
}

void PartSceneRenderer::render(const PartScene& scene, cv::Mat& dst, std::uint64_t noiseIndex) const {
  dst.create(options_.height, options_.width, CV_8UC1);
  dst.setTo(cv::Scalar(options_.background));
  if (options_.fiducialDiameterMm > 0) {
    // A 96-gon on the plane, anti-aliased (1/16 px vertices); parts may lie on it.
    std::vector<cv::Point> disk;
    const double r = options_.fiducialDiameterMm / 2;
    for (int k = 0; k < 96; ++k) {
      const double a = 2 * M_PI * k / 96;
      if (const auto px = camera_.project({options_.fiducialXMm + r * std::cos(a), options_.fiducialYMm + r * std::sin(a), 0.0}))
        disk.emplace_back(cvRound(px->u * 16), cvRound(px->v * 16));
    }
    if (disk.size() >= 3)
      cv::fillPoly(dst, std::vector<std::vector<cv::Point>>{disk}, cv::Scalar(options_.fiducialGray), cv::LINE_AA, 4);
  }
  std::mt19937_64 rng(options_.seed * 0xD1B54A32D192ED03ull + scene.index * 0x94D049BB133111EBull + 5);
  std::uniform_real_distribution<double> unit(0.0, 1.0);

  // Clutter: flat distractor shapes on the belt, clear of the parts.
  std::vector<cv::Rect2d> parts;
  for (const auto& p : scene.parts) parts.push_back(footprint(camera_, model(p.classIndex), p));
  const double pxPerMm = focal_ / options_.cameraHeightMm;
  for (int k = 0; k < options_.clutter; ++k) {
    for (int attempt = 0; attempt < 50; ++attempt) {
      const double cx = unit(rng) * options_.width, cy = unit(rng) * options_.height;
      const double r = (6 + 24 * unit(rng)) * pxPerMm;
      const cv::Rect2d box(cx - r - 4, cy - r - 4, 2 * r + 8, 2 * r + 8);
      if (std::any_of(parts.begin(), parts.end(), [&](const cv::Rect2d& b) { return (b & box).area() > 0; })) continue;
      const int kind = static_cast<int>(unit(rng) * 3);
      const int gray = 60 + static_cast<int>(unit(rng) * 170);
      if (kind == 0) {
        cv::circle(dst, cv::Point(cvRound(cx * 16), cvRound(cy * 16)), cvRound(r * 16), cv::Scalar(gray), cv::FILLED,
                   cv::LINE_AA, 4);
      } else {
        // A random polygon (kind 1) or a bar (kind 2).
        std::vector<cv::Point> poly;
        const int n = kind == 1 ? 3 + static_cast<int>(unit(rng) * 4) : 4;
        const double a0 = unit(rng) * 2 * M_PI;
        for (int i = 0; i < n; ++i) {
          const double a = a0 + 2 * M_PI * i / n + (kind == 1 ? 0.5 * unit(rng) : 0);
          const double rr = kind == 1 ? r * (0.5 + 0.5 * unit(rng)) : r * (i % 2 ? 0.25 : 1.0);
          poly.emplace_back(cvRound((cx + rr * std::cos(a)) * 16), cvRound((cy - rr * std::sin(a)) * 16));
        }
        cv::fillPoly(dst, std::vector<std::vector<cv::Point>>{poly}, cv::Scalar(gray), cv::LINE_AA, 4);
      }
      break;
    }
  }

  if (options_.decoys > 0) drawDecoys(scene, dst);
  for (const auto& p : scene.parts) drawPart(p, dst);

  cv::Mat f;
  dst.convertTo(f, CV_32FC1);
  if (options_.illumRatio > 1) {
    // Linear lighting gradient in a random direction: gain 1 on one side, 1/ratio on the other.
    const double dir = unit(rng) * 2 * M_PI, dx = std::cos(dir), dy = std::sin(dir);
    const double span = std::abs(dx) * (options_.width - 1) + std::abs(dy) * (options_.height - 1);
    const double lo = std::min(0.0, dx * (options_.width - 1)) + std::min(0.0, dy * (options_.height - 1));
    const double k = 1 - 1 / options_.illumRatio;
    for (int y = 0; y < f.rows; ++y) {
      auto* row = f.ptr<float>(y);
      for (int x = 0; x < f.cols; ++x) row[x] *= static_cast<float>(1 - k * ((dx * x + dy * y - lo) / span));
    }
  }
  if (options_.blurSigma > 0) cv::GaussianBlur(f, f, cv::Size(), options_.blurSigma);
  if (options_.noiseSigma > 0) {
    cv::Mat noise(f.size(), CV_32FC1);
    cv::RNG nrng(options_.seed * 0x2545F4914F6CDD1Dull + noiseIndex * 0x9E3779B97F4A7C15ull + 3);
    nrng.fill(noise, cv::RNG::NORMAL, 0, options_.noiseSigma);
    f += noise;
  }
  f.convertTo(dst, CV_8UC1);  // rounds and saturates
}

PartTemplate PartSceneRenderer::renderTemplate(cv::Mat& dst) const {
  PartScene scene;
  scene.parts.push_back(place(options_.cameraXMm, options_.cameraYMm, 0));
  cv::Mat full(options_.height, options_.width, CV_8UC1, cv::Scalar(options_.background));
  drawPart(scene.parts.front(), full);
  const cv::Rect2d fp = footprint(camera_, part_, scene.parts.front());
  constexpr int kMargin = 24;
  cv::Rect crop(static_cast<int>(std::floor(fp.x)) - kMargin, static_cast<int>(std::floor(fp.y)) - kMargin,
                static_cast<int>(std::ceil(fp.width)) + 2 * kMargin, static_cast<int>(std::ceil(fp.height)) + 2 * kMargin);
  crop &= cv::Rect(0, 0, full.cols, full.rows);
  full(crop).copyTo(dst);
  PartTemplate t;
  t.offsetX = crop.x;
  t.offsetY = crop.y;
  t.graspU = scene.parts.front().uPx - crop.x;
  t.graspV = scene.parts.front().vPx - crop.y;
  for (const auto& l : part_.layers) {
    PartTemplate::Region r;
    r.heightMm = l.topMm;
    for (const auto& q : l.outline) {
      const cv::Point2d a = projectPart(camera_, scene.parts.front(), q, l.topMm);
      r.polygon.push_back({a.x - crop.x, a.y - crop.y});
    }
    t.regions.push_back(std::move(r));
  }
  return t;
}

}  // namespace vgr::sim
