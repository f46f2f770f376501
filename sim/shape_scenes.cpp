#include "sim/shape_scenes.hpp"

#include <algorithm>
#include <cmath>
#include <functional>
#include <numbers>
#include <random>

#include <fmt/core.h>
#include <opencv2/imgproc.hpp>

namespace vgr::sim::shapes {
namespace {

constexpr double kPi = std::numbers::pi;
using Poly = std::vector<cv::Point2d>;

// Points of the arc of radius r about c from angle a0 to a1 (rad, y down: angle measured
// from +x toward +y), the end excluded; at most 0.01 px from the true circle.
void appendArc(Poly& out, cv::Point2d c, double r, double a0, double a1) {
  const double maxStep = 2 * std::sqrt(2 * 0.01 / std::max(r, 1.0));
  const int n = std::max(1, static_cast<int>(std::ceil(std::abs(a1 - a0) / maxStep)));
  for (int i = 0; i < n; ++i) {
    const double a = a0 + (a1 - a0) * i / n;
    out.emplace_back(c.x + r * std::cos(a), c.y + r * std::sin(a));
  }
}

Poly circle(cv::Point2d c, double r) {
  Poly p;
  appendArc(p, c, r, 0, 2 * kPi);
  return p;
}

// A slot (two half circles joined by straight sides) of length `len` (end to end) and width
// `w`, centred at c, its long axis at angle a (rad, y down).
Poly slot(cv::Point2d c, double len, double w, double a) {
  const double h = (len - w) / 2, r = w / 2;
  const cv::Point2d d(std::cos(a), std::sin(a));
  Poly p;
  appendArc(p, c + h * d, r, a - kPi / 2, a + kPi / 2);
  appendArc(p, c - h * d, r, a + kPi / 2, a + 3 * kPi / 2);
  return p;
}

double radiusOf(const ShapePart& part) {
  double r = 0;
  for (const auto& s : part.solids)
    for (const auto& p : s) r = std::max(r, std::hypot(p.x, p.y));
  return r;
}

// Exact area coverage of polygons, the accumulation idea of font rasterisers: for every edge,
// each pixel row it crosses gets, per pixel, the change from the pixel to its left of the
// area to the right of the edge within the row; a running sum along the row then gives the
// signed covered area of every pixel. Derivation: a piece of an edge within a row, of signed
// height h (+ downward) spanning x in [x0, x1], covers to its right in column i the area
// f(i) = h / (x1 - x0) * (R(i + 1 - x0) - R(i + 1 - x1)), with R(t) the integral of
// clamp(t, 0, 1) (0, t^2 / 2, t - 1/2 for t below 0, in [0, 1], above 1); acc[i] += f(i) - f(i - 1).
// Cells: pixel (i, j) covers [i, i + 1) x [j, j + 1) (pixel centres at +0.5).
class Coverage {
 public:
  Coverage(int w, int h) : w_(w), h_(h), acc_(static_cast<std::size_t>(w + 2) * h, 0.0) {}

  // Adds the polygon with weight `sign` inside (+1 a solid, -1 a hole), whatever its orientation.
  void add(const Poly& poly, double sign) {
    double area2 = 0;
    for (std::size_t k = 0; k < poly.size(); ++k) {
      const auto& p = poly[k];
      const auto& q = poly[(k + 1) % poly.size()];
      area2 += p.x * q.y - q.x * p.y;
    }
    // With y down, downward edges adding to their right makes a polygon of positive area2 -1 inside.
    const double mult = area2 > 0 ? -sign : sign;
    for (std::size_t k = 0; k < poly.size(); ++k) edge(poly[k], poly[(k + 1) % poly.size()], mult);
  }

  // Coverage of pixel (i, j) in [0, 1], for i in [0, w), row by row (running sums).
  void rows(const std::function<void(int, const double*)>& fn) const {
    std::vector<double> cov(static_cast<std::size_t>(w_));
    for (int j = 0; j < h_; ++j) {
      const double* a = acc_.data() + static_cast<std::size_t>(j) * (w_ + 2);
      double sum = 0;
      for (int i = 0; i < w_; ++i) cov[i] = std::clamp(sum += a[i], 0.0, 1.0);
      fn(j, cov.data());
    }
  }

 private:
  static double integralClamp(double t) { return t <= 0 ? 0.0 : t <= 1 ? 0.5 * t * t : t - 0.5; }

  void edge(cv::Point2d p, cv::Point2d q, double mult) {
    if (p.y == q.y) return;
    const double dir = p.y < q.y ? 1.0 : -1.0;
    if (p.y > q.y) std::swap(p, q);
    const double dxdy = (q.x - p.x) / (q.y - p.y);
    for (int j = std::max(0, static_cast<int>(std::floor(p.y))); j < std::min(h_, static_cast<int>(std::ceil(q.y))); ++j) {
      const double ya = std::max(p.y, double(j)), yb = std::min(q.y, double(j + 1));
      if (yb <= ya) continue;
      const double h = (yb - ya) * dir * mult;
      const double xa = p.x + (ya - p.y) * dxdy, xb = p.x + (yb - p.y) * dxdy;
      const double x0 = std::min(xa, xb), x1 = std::max(xa, xb);
      double* a = acc_.data() + static_cast<std::size_t>(j) * (w_ + 2);
      const int i0 = static_cast<int>(std::floor(x0)), i1 = static_cast<int>(std::ceil(x1));
      double prev = 0;
      for (int i = i0; i <= i1; ++i) {
        const double f = x1 - x0 > 1e-12 ? h / (x1 - x0) * (integralClamp(i + 1 - x0) - integralClamp(i + 1 - x1))
                                          : h * std::clamp(i + 1 - x0, 0.0, 1.0);
        a[std::clamp(i, 0, w_ + 1)] += f - prev;  // left of the buffer: into its first cell
        prev = f;
      }
    }
  }

  int w_, h_;
  std::vector<double> acc_;
};

// Composites the part at `pose` into the float image `img` (gray levels): exact coverage a,
// value bg (what is there) * (1 - a) + fg * a. Holes lie inside the solids, apart.
void drawPart(const ShapePart& part, const ShapePose& pose, double fg, cv::Mat& img) {
  std::vector<Poly> solids, holes;
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (const auto& s : part.solids) {
    Poly q;
    for (const auto& p : s) {
      q.push_back(mapPoint(pose, p));
      x0 = std::min(x0, q.back().x), x1 = std::max(x1, q.back().x);
      y0 = std::min(y0, q.back().y), y1 = std::max(y1, q.back().y);
    }
    solids.push_back(std::move(q));
  }
  for (const auto& h : part.holes) {
    Poly q;
    for (const auto& p : h) q.push_back(mapPoint(pose, p));
    holes.push_back(std::move(q));
  }
  const cv::Rect box = cv::Rect(static_cast<int>(std::floor(x0)) - 2, static_cast<int>(std::floor(y0)) - 2,
                                static_cast<int>(std::ceil(x1 - x0)) + 5, static_cast<int>(std::ceil(y1 - y0)) + 5) &
                       cv::Rect(0, 0, img.cols, img.rows);
  if (box.empty()) return;
  // Image px -> cells of the box: pixel centre x sits at cell x - box.x + 0.5.
  Coverage cov(box.width, box.height);
  auto toCells = [&](Poly poly) {
    for (auto& p : poly) p = {p.x - box.x + 0.5, p.y - box.y + 0.5};
    return poly;
  };
  for (const auto& s : solids) cov.add(toCells(s), 1.0);
  for (const auto& h : holes) cov.add(toCells(h), -1.0);
  cv::Mat roi = img(box);
  cov.rows([&](int j, const double* a) {
    float* r = roi.ptr<float>(j);
    for (int i = 0; i < roi.cols; ++i) r[i] = static_cast<float>(r[i] * (1 - a[i]) + fg * a[i]);
  });
}

void finish(cv::Mat& img, double noiseSigma, std::uint64_t seed, cv::Mat& dst) {
  if (noiseSigma > 0) {
    cv::Mat noise(img.size(), CV_32F);
    cv::RNG rng(seed * 0x9E3779B97F4A7C15ull + 11);
    rng.fill(noise, cv::RNG::NORMAL, 0, noiseSigma);
    img += noise;
  }
  img.convertTo(dst, CV_8U);  // rounds and saturates
}

}  // namespace

cv::Point2d mapPoint(const ShapePose& pose, cv::Point2d p) {
  const double a = pose.angleDeg * kPi / 180, c = std::cos(a), s = std::sin(a);
  // Counter-clockwise as displayed with y down: (x, y) -> (x cos a + y sin a, -x sin a + y cos a).
  const double ax = pose.scale * (c * p.x + s * p.y), ay = pose.scale * (-s * p.x + c * p.y);
  const double w = 1 + pose.perspective.x * ax + pose.perspective.y * ay;
  return {pose.u + ax / w, pose.v + ay / w};
}

ShapePart gear(double diameterPx, int teeth) {
  ShapePart g;
  g.name = "gear";
  const double ro = diameterPx / 2, m = diameterPx / (teeth + 2), rp = m * teeth / 2, rr = rp - 1.25 * m;
  const double pitch = 2 * kPi / teeth;
  const double wRoot = 0.58 * pitch, wTip = 0.26 * pitch;  // angular widths of a tooth at root and tip
  Poly outline;
  for (int i = 0; i < teeth; ++i) {
    const double c = i * pitch;
    appendArc(outline, {0, 0}, rr, c - pitch + wRoot / 2, c - wRoot / 2);  // the gap before tooth i
    outline.emplace_back(rr * std::cos(c - wRoot / 2), rr * std::sin(c - wRoot / 2));
    appendArc(outline, {0, 0}, ro, c - wTip / 2, c + wTip / 2);
    outline.emplace_back(ro * std::cos(c + wTip / 2), ro * std::sin(c + wTip / 2));
  }
  g.solids.push_back(std::move(outline));
  // The bore with a keyway (up): the circle from the keyway's right side round to its left,
  // then the keyway's three sides.
  const double bore = 0.2 * ro, kw = 0.045 * ro, top = bore + 0.07 * ro;
  const double side = std::asin(kw / bore);  // the keyway's sides meet the circle at -pi/2 +- side
  Poly bored;
  appendArc(bored, {0, 0}, bore, -kPi / 2 + side, 3 * kPi / 2 - side);
  bored.emplace_back(-kw, -bore * std::cos(side));
  bored.emplace_back(-kw, -top);
  bored.emplace_back(kw, -top);
  bored.emplace_back(kw, -bore * std::cos(side));
  g.holes.push_back(std::move(bored));
  for (int k = 0; k < 5; ++k) {
    const double a = -kPi / 2 + kPi / 5 + k * 2 * kPi / 5;
    g.holes.push_back(circle({0.52 * ro * std::cos(a), 0.52 * ro * std::sin(a)}, 0.11 * ro));
  }
  g.radius = radiusOf(g);
  return g;
}

ShapePart slottedPlate(double lengthPx) {
  ShapePart p;
  p.name = "plate";
  const double l = lengthPx, w = 0.62 * l, hx = l / 2, hy = w / 2, cr = 0.05 * l;
  // Clockwise as displayed from the top left corner: a notch in the top side, rounded corners
  // but a chamfer at the bottom right.
  const double ch = 0.11 * l;
  Poly outline;
  appendArc(outline, {-hx + cr, -hy + cr}, cr, kPi, 3 * kPi / 2);
  outline.emplace_back(-0.2 * l, -hy);
  outline.emplace_back(-0.2 * l, -hy + 0.08 * l);
  outline.emplace_back(-0.08 * l, -hy + 0.08 * l);
  outline.emplace_back(-0.08 * l, -hy);
  appendArc(outline, {hx - cr, -hy + cr}, cr, -kPi / 2, 0);
  outline.emplace_back(hx, hy - ch);
  outline.emplace_back(hx - ch, hy);
  appendArc(outline, {-hx + cr, hy - cr}, cr, kPi / 2, kPi);
  p.solids.push_back(std::move(outline));
  p.holes.push_back(slot({-0.3 * l, -0.12 * l}, 0.16 * l, 0.05 * l, 0));
  p.holes.push_back(slot({-0.3 * l, 0.1 * l}, 0.16 * l, 0.05 * l, 0));
  p.holes.push_back(slot({-0.02 * l, 0.05 * l}, 0.2 * l, 0.05 * l, kPi / 2));
  p.holes.push_back(slot({0.1 * l, 0.05 * l}, 0.2 * l, 0.05 * l, kPi / 2));
  p.holes.push_back(slot({0.3 * l, -0.13 * l}, 0.14 * l, 0.045 * l, kPi / 4));
  p.holes.push_back(slot({0.29 * l, 0.12 * l}, 0.12 * l, 0.045 * l, -kPi / 6));
  p.holes.push_back(circle({-0.42 * l, -0.22 * l}, 0.025 * l));
  p.holes.push_back(circle({0.2 * l, -0.2 * l}, 0.04 * l));
  p.holes.push_back(circle({-0.12 * l, 0.2 * l}, 0.035 * l));
  p.radius = radiusOf(p);
  return p;
}

Result<ShapePart> partByName(const std::string& name, double sizePx) {
  if (!(sizePx >= 20 && sizePx <= 4000)) return fail(Status::BadArgument, fmt::format("part size {} px: expected [20, 4000]", sizePx));
  if (name == "gear") return gear(sizePx);
  if (name == "plate") return slottedPlate(sizePx);
  return fail(Status::BadArgument, fmt::format("unknown part '{}': expected gear or plate", name));
}

void renderScene(const ShapePart& part, const std::vector<ShapePose>& poses, const ShapeSceneOptions& o, cv::Mat& dst) {
  cv::Mat img(o.size, CV_32F, cv::Scalar(o.background));
  std::mt19937_64 rng(o.seed * 0x2545F4914F6CDD1Dull + 5);
  std::uniform_real_distribution<double> u01(0, 1);
  // Clutter: shapes whose bounding circle keeps 12 px clear of every part's.
  for (int k = 0; k < o.clutter; ++k) {
    for (int attempt = 0; attempt < 200; ++attempt) {
      const double size = 30 + 170 * u01(rng);
      const cv::Point2d c(size + u01(rng) * (o.size.width - 2 * size), size + u01(rng) * (o.size.height - 2 * size));
      bool clear = true;
      for (const auto& p : poses)
        clear = clear && std::hypot(c.x - p.u, c.y - p.v) > size + part.radius * p.scale * 1.05 + 12;
      if (!clear) continue;
      const double gray = 70 + 160 * u01(rng), a = u01(rng) * 2 * kPi;
      const int type = static_cast<int>(u01(rng) * 4);
      std::vector<cv::Point> pts;
      auto at = [&](double x, double y) {
        pts.emplace_back(cvRound((c.x + x * std::cos(a) - y * std::sin(a)) * 16), cvRound((c.y + x * std::sin(a) + y * std::cos(a)) * 16));
      };
      if (type == 0) {  // rectangle
        const double h = size * (0.3 + 0.7 * u01(rng));
        at(-size, -h), at(size, -h), at(size, h), at(-size, h);
      } else if (type == 1) {  // disc
        for (int i = 0; i < 64; ++i) at(size * std::cos(i * kPi / 32), size * std::sin(i * kPi / 32));
      } else if (type == 2) {  // triangle
        at(-size, -size * 0.8), at(size, -size * 0.2), at(-size * 0.3, size);
      } else {  // bar
        at(-size, -size * 0.12), at(size, -size * 0.12), at(size, size * 0.12), at(-size, size * 0.12);
      }
      cv::fillPoly(img, std::vector<std::vector<cv::Point>>{pts}, cv::Scalar(gray), cv::LINE_AA, 4);
      break;
    }
  }
  for (const auto& p : poses) drawPart(part, p, o.foreground, img);
  if (o.illumRatio > 1) {
    // Gain 1 at one corner falling linearly to 1 / ratio at the opposite one, along a random direction.
    const double a = u01(rng) * 2 * kPi, dx = std::cos(a), dy = std::sin(a);
    double lo = 1e18, hi = -1e18;
    for (const cv::Point2d q : {cv::Point2d(0, 0), cv::Point2d(o.size.width, 0), cv::Point2d(0, o.size.height),
                                cv::Point2d(o.size.width, o.size.height)}) {
      lo = std::min(lo, q.x * dx + q.y * dy), hi = std::max(hi, q.x * dx + q.y * dy);
    }
    const double k = (1 - 1 / o.illumRatio) / (hi - lo);
    for (int y = 0; y < img.rows; ++y) {
      float* r = img.ptr<float>(y);
      for (int x = 0; x < img.cols; ++x) r[x] *= static_cast<float>(1 - k * (x * dx + y * dy - lo));
    }
  }
  finish(img, o.noiseSigma, o.seed, dst);
}

ShapeTemplate renderTemplate(const ShapePart& part, int marginPx, double noiseSigma, std::uint64_t seed,
                             std::uint8_t background, std::uint8_t foreground) {
  ShapeTemplate t;
  // Crop to the part's bounding box (plus margin) rather than its circle.
  double x0 = 1e18, y0 = 1e18, x1 = -1e18, y1 = -1e18;
  for (const auto& s : part.solids)
    for (const auto& p : s) x0 = std::min(x0, p.x), x1 = std::max(x1, p.x), y0 = std::min(y0, p.y), y1 = std::max(y1, p.y);
  const int left = static_cast<int>(std::ceil(-x0)) + marginPx, top = static_cast<int>(std::ceil(-y0)) + marginPx;
  const cv::Size size(left + static_cast<int>(std::ceil(x1)) + marginPx + 1, top + static_cast<int>(std::ceil(y1)) + marginPx + 1);
  cv::Mat img(size, CV_32F, cv::Scalar(background));
  ShapePose pose;
  pose.u = left, pose.v = top;
  drawPart(part, pose, foreground, img);
  finish(img, noiseSigma, seed, t.image);
  t.graspU = left, t.graspV = top;
  return t;
}

std::vector<ShapePose> randomPoses(const ShapePart& part, cv::Size size, int count, double angleRangeDeg,
                                   double scaleMin, double scaleMax, double perspective, int marginPx,
                                   std::uint64_t seed) {
  std::mt19937_64 rng(seed * 1000003 + 29);
  std::uniform_real_distribution<double> u01(0, 1);
  const double reach = part.radius * scaleMax * (1 + perspective * part.radius * scaleMax) + marginPx;
  std::vector<ShapePose> out;
  for (int i = 0; i < count; ++i) {
    ShapePose p;
    p.u = reach + u01(rng) * (size.width - 1 - 2 * reach);
    p.v = reach + u01(rng) * (size.height - 1 - 2 * reach);
    p.angleDeg = (2 * u01(rng) - 1) * angleRangeDeg;
    p.scale = scaleMin + u01(rng) * (scaleMax - scaleMin);
    const double a = u01(rng) * 2 * kPi;
    p.perspective = {perspective * std::cos(a), perspective * std::sin(a)};
    out.push_back(p);
  }
  return out;
}

}  // namespace vgr::sim::shapes
