#include "vision/locate/shape_matcher.hpp"

#include <algorithm>
#include <cmath>
#include <ctime>
#include <map>
#include <string>
#include <numbers>

#include <Eigen/Dense>
#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "core/angles.hpp"
#include "vision/locate/params.hpp"
#include "vision/locate/shape_model.hpp"
#include "vision/locate/shape_simd.hpp"

namespace vgr::vision {
namespace {

using shape::LevelModel;
using shape::Model;
using shape::kChunkPoints;
using shape::kReadSlack;
using shape::kResponseMax;

constexpr double kCoarseSlack = 0.85;  // coarse levels accept minScore * this (blur, rounding)
constexpr int kBorderFlags = cv::BORDER_REPLICATE | cv::BORDER_ISOLATED;

double angleDist(double a, double b) { return std::abs(std::remainder(a - b, 2 * std::numbers::pi)); }

// Wall and process CPU time per stage of one locate() call (ShapeStageTimes): ~10 clock reads
// per call.
class StageClock {
 public:
  explicit StageClock(ShapeStageTimes& t) : t_(t) {
    t_ = ShapeStageTimes{};
    read(wall_, cpu_);
  }
  void lap(ShapeStageTimes::Stage stage) {
    double wall = 0, cpu = 0;
    read(wall, cpu);
    t_.wallMs[stage] += wall - wall_, t_.cpuMs[stage] += cpu - cpu_;
    wall_ = wall, cpu_ = cpu;
  }

 private:
  static void read(double& wallMs, double& cpuMs) {
    timespec w{}, c{};
    clock_gettime(CLOCK_MONOTONIC, &w);
    clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &c);
    wallMs = w.tv_sec * 1e3 + w.tv_nsec * 1e-6, cpuMs = c.tv_sec * 1e3 + c.tv_nsec * 1e-6;
  }
  ShapeStageTimes& t_;
  double wall_ = 0, cpu_ = 0;
};

constexpr int kBins = 16;              // quantised gradient directions of the top-level response maps (22.5 deg each)
constexpr double kBeatenMargin = 0.1;  // pruneBeaten: a score this far below an overlapping candidate's

struct Candidate {
  double x = 0, y = 0;  // model origin, px of `level` (ROI coordinates)
  double phi = 0;       // rad, image rotation (x right, y down: clockwise as displayed)
  double score = 0;     // [-1, 1]
  int sign = 1;         // -1: inverted contrast (polarity ignore_global)
  double scale = 1;     // image px per template px
  int level = 0;        // the pyramid level (x, y) are in
  double angleStep = 0;  // rad: the angle step of the search that found it at `level`
  double scaleStep = 0;  // its scale step there (0 without a scale range)
  bool fromTop = false;  // found by the top-level search (not yet tracked)
};

// One (angle, scale) of the top-level search: its points, rounded to the top level's pixels,
// are Band::dx/dy/bin [first, first + count).
struct TopModel {
  double phi = 0, scale = 1;
  double angleStep = 0;  // rad: the top-level angle step at this scale
  int first = 0, count = 0;
};

// The scales searched from one top level (HALCON-style scaled models: a part seen smaller
// is searched from a lower level, so that every top level sees the part with a radius of
// >= 8 px; a fixed-scale job has one band). Per image size: the response maps.
struct Band {
  int level = 0;
  double scaleStep = 0;  // between its scales (0: one scale)
  int pad = 0;           // px around the top image: the farthest model point
  std::vector<TopModel> models;
  std::vector<std::int16_t> dx, dy;
  std::vector<std::uint8_t> bin;
  // Per image size (prepare()).
  int w = 0, h = 0, stride = 0, mapSize = 0;
  std::vector<std::int32_t> offsets;  // per point: bin * mapSize + (dy + pad) * stride + dx + pad
  std::vector<std::uint8_t> resp;     // kBins maps of (h + 2 pad) x stride, + kReadSlack
};

// A share of the top-level search for one task of the worker pool: models [first, last) of
// one band, with its own row buffers and candidate list (allocated per image size).
struct WorkItem {
  int band = 0, first = 0, last = 0;
  std::vector<std::uint16_t> acc;    // one row's sums (+ slack for the SIMD stores)
  std::vector<std::uint16_t> ring;   // the last three rows' sums (local maxima)
  std::vector<std::uint8_t> alive;   // the last three rows: not dropped by early termination
  std::vector<Candidate> found;
};

// A model rotated and scaled for one pose (rotateModel), in one level's px: the scratch of one
// task (tracking, peak interpolation, refinement); one per candidate searched in parallel.
struct Rotated {
  std::vector<float> rx, ry;    // px from the origin
  std::vector<float> nx, ny;    // unit gradient direction
  std::vector<int> ix, iy;      // rounded
  std::vector<int> lin;         // iy * row step + ix: the offset in nx_/ny_ of its level
  cv::Rect box;                 // the rounded points' bounding box (px, relative to the origin)
  int count = 0;
  void resize(std::size_t n) { rx.resize(n), ry.resize(n), nx.resize(n), ny.resize(n), ix.resize(n), iy.resize(n), lin.resize(n); }
};

constexpr int kTile = 32;  // px: the lower levels' unit gradient is computed in tiles of this size, once each

class ShapeLocator final : public Locator {
 public:
  ShapeLocator(ShapeParams params, Model model, const TaughtTemplate& taught)
      : p_(params), m_(std::move(model)), taught_(taught) {
    fullCircle_ = taught.angleMaxDeg - taught.angleMinDeg >= 360 - 1e-9;
    scaleSearch_ = taught.scaleMax > taught.scaleMin;
    buildBands();
    // Equivalent circle of the part (at scale 1) for overlap control: the level-0 points' bounding box.
    const LevelModel& m0 = m_.levels[0];
    const auto [x0, x1] = std::minmax_element(m0.x.begin(), m0.x.end());
    const auto [y0, y1] = std::minmax_element(m0.y.begin(), m0.y.end());
    eqRadius_ = std::sqrt((*x1 - *x0) * (*y1 - *y0) / std::numbers::pi);
    std::size_t maxPts = 0;
    for (const auto& l : m_.levels) maxPts = std::max(maxPts, l.x.size());
    // One scratch per candidate tracked at once (at most `keep` of them, see locate()).
    scratch_.resize(static_cast<std::size_t>(4 * taught.maxParts + 4));
    for (Rotated& r : scratch_) r.resize(maxPts);
    assignGraspRegion(taught);
  }

  // The grasp point's region: the smallest region polygon containing it (a boss on a plate
  // lies inside the plate's outline too), else the nearest. Its model points are the level-0
  // points within 3 px of or inside its polygon. Fewer than 12 points: no region settling.
  void assignGraspRegion(const TaughtTemplate& taught) {
    if (p_.regionShiftPx <= 0 || taught.regions.size() < 2) return;
    int best = -1;
    double bestArea = 0, bestDist = -1e18;
    std::vector<std::vector<cv::Point2f>> polys;
    for (const auto& r : taught.regions) {
      std::vector<cv::Point2f> poly;
      for (const auto& q : r.polygon) poly.emplace_back(static_cast<float>(q.u), static_cast<float>(q.v));
      polys.push_back(poly);
    }
    const cv::Point2f g(static_cast<float>(taught.grasp.u), static_cast<float>(taught.grasp.v));
    for (std::size_t i = 0; i < polys.size(); ++i) {
      if (polys[i].size() < 3) continue;
      const double d = cv::pointPolygonTest(polys[i], g, true);
      const double area = cv::contourArea(polys[i]);
      const bool inside = d >= 0;
      const bool bestInside = bestDist >= 0;
      if (best < 0 || (inside && (!bestInside || area < bestArea)) || (!inside && !bestInside && d > bestDist))
        best = static_cast<int>(i), bestArea = area, bestDist = d;
    }
    if (best < 0) return;
    const LevelModel& m0 = m_.levels[0];
    for (int k = 0; k < m0.size(); ++k) {
      const cv::Point2f q(static_cast<float>(m0.x[k] + m_.origin.u), static_cast<float>(m0.y[k] + m_.origin.v));
      if (cv::pointPolygonTest(polys[best], q, true) >= -3.0) graspRegionPts_.push_back(k);
    }
    if (graspRegionPts_.size() < 12 || graspRegionPts_.size() == static_cast<std::size_t>(m0.size())) graspRegionPts_.clear();
  }

  std::string_view method() const override { return "shape"; }

  Result<LocateOutput> locate(const cv::Mat& gray) override;

  const ShapeStageTimes& stageTimes() const { return times_; }

 private:
  // rad: the search's angle step at `level` for a part at `scale` (1 px at its rim, or the
  // job's angle_step_deg).
  double angleStep(int level, double scale) const {
    const double step = m_.levels[level].angleStep;
    return p_.angleStepDeg > 0 ? step : std::min(step / scale, 0.5);
  }
  // The scale step at `level`: 1 px at the rim of the part (at scale 1) at that level.
  double scaleStep(int level) const { return std::ldexp(1.0, level) / std::max(m_.levels[0].radius, 1.0); }
  // The top level for a part at `scale`: the job's `levels` - 1, or the highest level at which
  // the part still has a radius of >= 8 px and >= 24 points (shape_model.hpp, buildModel).
  int topLevelFor(double scale) const;
  void buildBands();

  void prepare(cv::Size roiSize);
  void responseMaps(Band& b);
  void searchTop(WorkItem& item, double thr);
  // The window of `level` around c (at that level) that a search there reads: the model at
  // any angle plus `extra` px; clipped to the image.
  cv::Rect windowAt(int level, const Candidate& c, double extra) const;
  // Marks the tiles of `level` that `r` covers and are not computed yet (tileTodo_).
  void needTiles(int level, cv::Rect r);
  // Computes the marked tiles (on the worker pool when there are enough).
  void computeTiles(int level);
  void smoothGradients(const Candidate& c);
  void rotateModel(Rotated& r, int level, double phi, double scale) const;
  double scoreAt(const Rotated& r, int level, int x, int y, int& sign) const;
  // The best of scoreAt over the positions (x0 + dx, y0 + dy), |dx|, |dy| <= rad, of the model
  // as rotated in r (phi, scale); updates best when better.
  void bestAround(const Rotated& r, int level, int x0, int y0, int rad, double phi, double scale, Candidate& best) const;
  // Hill-climb at `level` over +-1 px and +-1 angle step around best, at most `rounds` times.
  void climb(Rotated& r, int level, Candidate& best, int rounds) const;
  bool trackDown(Rotated& r, Candidate& c, double thr) const;
  void interpolatePeak(Rotated& r, Candidate& c) const;
  void refine(Rotated& r, Candidate& c) const;
  void suppress(std::vector<Candidate>& cands, double distPx, double angle, std::size_t keep) const;
  // Drops candidates at `level` that overlap a better one there (the final overlap control's
  // equivalent circles) and score kBeatenMargin or more below it: one part has one pose, and
  // below the top the scores are exact.
  void pruneBeaten(std::vector<Candidate>& cands, int level) const;
  bool overlap(const Candidate& a, const Candidate& b) const;
  void settleGraspRegion(Rotated& r, const Candidate& c, double& tx, double& ty) const;
  // Runs fn(i) for i in [0, n): on OpenCV's pool with workers > 1 (one task per i, taken as
  // workers free up), else in order.
  template <class Fn>
  void forEach(int n, const Fn& fn) const;

  ShapeParams p_;
  Model m_;
  TaughtTemplate taught_;
  bool fullCircle_ = true;
  bool scaleSearch_ = false;
  int maxTop_ = 0;            // the highest top level of any band
  double maxTopStep_ = 0;     // rad: the largest top-level angle step
  double eqRadius_ = 0;
  std::vector<Band> bands_;
  std::vector<WorkItem> items_;

  // Per image size (prepare()).
  cv::Size roiSize_;
  std::vector<cv::Mat> pyr_;            // [0] = a view of the live image's ROI
  std::vector<cv::Mat> nx_, ny_;        // unit gradient direction, 0 below minContrast (computed tiles only)
  std::vector<std::vector<std::uint32_t>> tileStamp_;  // per level and tile: the call that computed it
  std::vector<int> tilesX_;             // tiles per row, per level
  std::vector<int> tileTodo_;           // tiles to compute (needTiles -> computeTiles)
  std::uint32_t serial_ = 0;            // this locate() call
  cv::Mat f32_, blur_, sgx_, sgy_;      // level 0: smoothed image and its gradient (refinement)
  cv::Mat s16x_, s16y_;                 // a top level's Sobel (16 bit)
  std::vector<float> unitX_, unitY_;    // one row's unit gradient (response maps)
  std::vector<Candidate> cands_, next_;
  std::vector<char> kept_;              // per candidate of a parallel step: still a candidate
  std::vector<Rotated> scratch_;        // per candidate of a parallel step
  // Height-aware grasp: indices of the level-0 model points on the grasp point's region.
  std::vector<int> graspRegionPts_;
  ShapeStageTimes times_;
};

int ShapeLocator::topLevelFor(double scale) const {
  if (p_.levels > 0) return std::min(p_.levels, m_.searchLevels) - 1;
  int top = 0;
  for (int l = 1; l < m_.searchLevels; ++l)
    if (m_.levels[0].radius * scale * std::ldexp(1.0, -l) >= 8 && m_.levels[m_.templateLevel(l, scale)].size() >= 24) top = l;
  return top;
}

// The (angle, scale) models of every band: scales from scaleMin up in steps of 1 px at the
// rim at their top level, each to the band of its top level; angles per scale 1 px at the
// rim (the job's range, or the full circle).
void ShapeLocator::buildBands() {
  const double smin = taught_.scaleMin, smax = taught_.scaleMax;
  std::vector<std::pair<int, double>> scales;  // (top level, scale)
  if (!scaleSearch_) {
    scales.emplace_back(topLevelFor(smin), smin);
  } else {
    for (double sc = smin;;) {
      const int top = topLevelFor(sc);
      scales.emplace_back(top, std::min(sc, smax));
      if (sc >= smax) break;
      sc += scaleStep(top);
      if (sc > smax && sc - scaleStep(top) < smax - 0.25 * scaleStep(top)) sc = smax;
    }
  }
  const double lo = -taught_.angleMaxDeg * std::numbers::pi / 180, hi = -taught_.angleMinDeg * std::numbers::pi / 180;
  for (const auto& [top, sc] : scales) {
    auto it = std::find_if(bands_.begin(), bands_.end(), [&](const Band& b) { return b.level == top; });
    if (it == bands_.end()) {
      bands_.push_back(Band{});
      bands_.back().level = top;
      bands_.back().scaleStep = scaleSearch_ ? scaleStep(top) : 0.0;
      it = bands_.end() - 1;
    }
    Band& band = *it;
    maxTop_ = std::max(maxTop_, top);
    const double step = angleStep(top, sc);
    int n = 0;
    double topStep = 0;
    if (fullCircle_) {
      n = static_cast<int>(std::ceil(2 * std::numbers::pi / step));
      topStep = 2 * std::numbers::pi / n;
    } else {
      n = std::max(1, static_cast<int>(std::ceil((hi - lo) / step)) + 1);
      topStep = n > 1 ? (hi - lo) / (n - 1) : step;
    }
    maxTopStep_ = std::max(maxTopStep_, topStep);
    const int tl = m_.templateLevel(top, sc);
    const LevelModel& tm = m_.levels[tl];
    const double f = sc * std::ldexp(1.0, tl - top);
    for (int i = 0; i < n; ++i) {
      TopModel r;
      r.phi = fullCircle_ ? i * topStep : lo + i * topStep;
      r.scale = sc;
      r.angleStep = topStep;
      r.first = static_cast<int>(band.dx.size());
      r.count = tm.size();
      const double c = std::cos(r.phi), s = std::sin(r.phi);
      for (int k = 0; k < tm.size(); ++k) {
        const int dx = cvRound(f * (c * tm.x[k] - s * tm.y[k])), dy = cvRound(f * (s * tm.x[k] + c * tm.y[k]));
        band.dx.push_back(static_cast<std::int16_t>(dx));
        band.dy.push_back(static_cast<std::int16_t>(dy));
        const double dir = std::atan2(s * tm.nx[k] + c * tm.ny[k], c * tm.nx[k] - s * tm.ny[k]);
        band.bin.push_back(static_cast<std::uint8_t>((static_cast<int>(std::lround(dir / (2 * std::numbers::pi / kBins))) + kBins) % kBins));
        band.pad = std::max(band.pad, std::max(std::abs(dx), std::abs(dy)) + 1);
      }
      band.models.push_back(r);
    }
  }
  // Work items: a few models each, so that a busy second core only delays the items it took.
  for (int b = 0; b < static_cast<int>(bands_.size()); ++b) {
    const int n = static_cast<int>(bands_[b].models.size());
    const int per = std::max(1, std::min(8, n / 16));
    for (int i = 0; i < n; i += per) items_.push_back({b, i, std::min(n, i + per), {}, {}, {}, {}});
  }
}

void ShapeLocator::prepare(cv::Size roiSize) {
  if (roiSize == roiSize_) return;
  roiSize_ = roiSize;
  const int levels = maxTop_ + 1;
  pyr_.assign(static_cast<std::size_t>(levels), cv::Mat());
  nx_.assign(pyr_.size(), cv::Mat()), ny_.assign(pyr_.size(), cv::Mat());
  tileStamp_.assign(pyr_.size(), {});
  tilesX_.assign(pyr_.size(), 0);
  std::size_t tiles = 0;
  std::vector<cv::Size> sizes;
  cv::Size s = roiSize;
  for (int l = 0; l < levels; ++l) {
    if (l > 0) {
      s = cv::Size((s.width + 1) / 2, (s.height + 1) / 2);
      pyr_[l].create(s, CV_8UC1);
    }
    sizes.push_back(s);
    nx_[l].create(s, CV_32F), ny_[l].create(s, CV_32F);
    tilesX_[l] = (s.width + kTile - 1) / kTile;
    tileStamp_[l].assign(static_cast<std::size_t>(tilesX_[l]) * ((s.height + kTile - 1) / kTile), 0);
    tiles += tileStamp_[l].size();
  }
  tileTodo_.clear();
  tileTodo_.reserve(tiles);
  serial_ = 0;
  f32_.create(roiSize, CV_32F), blur_.create(roiSize, CV_32F);
  sgx_.create(roiSize, CV_32F), sgy_.create(roiSize, CV_32F);
  // Touch every page now: windows land anywhere, and first-touch page faults in the middle
  // of a search cost tens of ms on a 5 MP image.
  for (std::size_t l = 0; l < pyr_.size(); ++l) nx_[l] = 0.f, ny_[l] = 0.f;
  f32_ = 0.f, blur_ = 0.f, sgx_ = 0.f, sgy_ = 0.f;
  int widest = 0;
  for (Band& b : bands_) {
    b.w = sizes[b.level].width, b.h = sizes[b.level].height;
    widest = std::max(widest, b.w);
    b.stride = b.w + 2 * b.pad;
    b.mapSize = b.stride * (b.h + 2 * b.pad);
    b.resp.assign(static_cast<std::size_t>(kBins) * b.mapSize + kReadSlack, 0);  // the padding stays 0: no edge
    b.offsets.resize(b.dx.size());
    for (std::size_t k = 0; k < b.dx.size(); ++k)
      b.offsets[k] = b.bin[k] * b.mapSize + (b.dy[k] + b.pad) * b.stride + b.dx[k] + b.pad;
  }
  int lowest = maxTop_;
  for (const Band& b : bands_) lowest = std::min(lowest, b.level);
  s16x_.create(sizes[lowest], CV_16S), s16y_.create(sizes[lowest], CV_16S);
  unitX_.assign(static_cast<std::size_t>(widest), 0.f), unitY_.assign(unitX_.size(), 0.f);
  for (WorkItem& it : items_) {
    const int w = bands_[it.band].w;
    it.acc.assign(static_cast<std::size_t>(w) + kReadSlack, 0);
    it.ring.assign(3 * static_cast<std::size_t>(w), 0);
    it.alive.assign(3, 0);
    it.found.clear();
    it.found.reserve(512);
  }
  cands_.reserve(4096), next_.reserve(4096), kept_.reserve(scratch_.size());
}

// The response maps of a band's top level (LINE-2D's idea, Hinterstoisser et al. 2012, with
// Steger's similarity): for every quantised model direction b (22.5 deg bins) and pixel, the
// similarity of a model point of direction b with the image there, cos of the angle between
// the bin's direction and the image gradient, clipped at 0 (polarity use; |cos| otherwise),
// in [0, kResponseMax]; 0 where the gradient is weaker than min_contrast. A model point's
// response is then one byte read, and the score an 8-bit sum (shape_simd.hpp). Clipping makes
// the top-level score an upper bound of Steger's eq. 3 (edges of the wrong sense subtract
// nothing), so it can only keep more candidates; the levels below score exactly.
void ShapeLocator::responseMaps(Band& b) {
  const cv::Mat& img = pyr_[b.level];
  cv::Mat sx = s16x_(cv::Rect(0, 0, img.cols, img.rows)), sy = s16y_(cv::Rect(0, 0, img.cols, img.rows));
  cv::Sobel(img, sx, CV_16S, 1, 0, 3, 1, 0, cv::BORDER_REPLICATE);
  cv::Sobel(img, sy, CV_16S, 0, 1, 3, 1, 0, cv::BORDER_REPLICATE);
  const float minC2 = static_cast<float>(p_.minContrast * p_.minContrast * 64.0);  // Sobel x 8
  const bool signedUse = p_.polarity == ShapePolarity::Use;
  float cb[kBins], sb[kBins];
  for (int k = 0; k < kBins; ++k) {
    cb[k] = static_cast<float>(std::cos(k * 2 * std::numbers::pi / kBins) * kResponseMax);
    sb[k] = static_cast<float>(std::sin(k * 2 * std::numbers::pi / kBins) * kResponseMax);
  }
  float* ux = unitX_.data();
  float* uy = unitY_.data();
  for (int y = 0; y < b.h; ++y) {
    const std::int16_t* gx = sx.ptr<std::int16_t>(y);
    const std::int16_t* gy = sy.ptr<std::int16_t>(y);
    for (int x = 0; x < b.w; ++x) {
      const float fx = gx[x], fy = gy[x], m2 = fx * fx + fy * fy;
      const float inv = m2 >= minC2 && m2 > 0 ? 1.0f / std::sqrt(m2) : 0.0f;
      ux[x] = fx * inv, uy[x] = fy * inv;
    }
    for (int k = 0; k < kBins; ++k) {
      std::uint8_t* out = b.resp.data() + static_cast<std::size_t>(k) * b.mapSize + (y + b.pad) * b.stride + b.pad;
      const float c = cb[k], s = sb[k];
      if (signedUse) {
        for (int x = 0; x < b.w; ++x) out[x] = static_cast<std::uint8_t>(std::max(0.0f, c * ux[x] + s * uy[x]) + 0.5f);
      } else {
        for (int x = 0; x < b.w; ++x) out[x] = static_cast<std::uint8_t>(std::abs(c * ux[x] + s * uy[x]) + 0.5f);
      }
    }
  }
}

// Scores every position of a band's top level for the item's models and collects the local
// maxima (8-neighbourhood, per model) above thr. Early termination per row (Steger 2002,
// sec. 3.2): after j of n points a row is dropped when its best partial sum is below
// (1 - g) * (n thr - n + j) + g * thr * j, the safe bound for g = 0 (every remaining point
// could still add 1) and the greedy one for g = 1 (the remaining points add thr each).
void ShapeLocator::searchTop(WorkItem& item, double thr) {
  const Band& b = bands_[item.band];
  const double g = p_.greediness;
  const int w = b.w;
  for (int mi = item.first; mi < item.last; ++mi) {
    const TopModel& model = b.models[mi];
    const int n = model.count;
    const std::int32_t* off = b.offsets.data() + model.first;
    const double full = static_cast<double>(kResponseMax) * n;
    const auto thrSum = static_cast<std::uint16_t>(std::min(65535.0, std::ceil(thr * full)));
    // Row y's sums go to ring row y % 3; local maxima of row y - 1 are taken once row y is in.
    auto peaksOf = [&](int y) {
      if (!item.alive[y % 3]) return;
      const std::uint16_t* row = item.ring.data() + static_cast<std::size_t>(y % 3) * w;
      const std::uint16_t* up = y > 0 && item.alive[(y + 2) % 3] ? item.ring.data() + static_cast<std::size_t>((y + 2) % 3) * w : nullptr;
      const std::uint16_t* down = y + 1 < b.h && item.alive[(y + 1) % 3] ? item.ring.data() + static_cast<std::size_t>((y + 1) % 3) * w : nullptr;
      for (int x = 0; x < w; ++x) {
        const std::uint16_t v = row[x];
        if (v < thrSum) continue;
        // Ties: the first in raster order wins.
        if ((x > 0 && row[x - 1] >= v) || (x + 1 < w && row[x + 1] > v)) continue;
        if (up && (up[x] >= v || (x > 0 && up[x - 1] >= v) || (x + 1 < w && up[x + 1] >= v))) continue;
        if (down && (down[x] > v || (x > 0 && down[x - 1] > v) || (x + 1 < w && down[x + 1] > v))) continue;
        if (item.found.size() == item.found.capacity()) {
          // Full: keep the better half (no reallocation on the hot path).
          std::nth_element(item.found.begin(), item.found.begin() + item.found.size() / 2, item.found.end(),
                           [](const Candidate& l, const Candidate& r) { return l.score > r.score; });
          item.found.resize(item.found.size() / 2);
        }
        Candidate c;
        c.x = x, c.y = y, c.phi = model.phi, c.score = v / full, c.scale = model.scale, c.level = b.level;
        c.angleStep = model.angleStep, c.scaleStep = b.scaleStep, c.fromTop = true;
        item.found.push_back(c);
      }
    };
    for (int y = 0; y < b.h; ++y) {
      std::uint16_t* acc = item.acc.data();
      std::fill(acc, acc + w, 0);
      const std::uint8_t* base = b.resp.data() + static_cast<std::size_t>(y) * b.stride;
      bool alive = true;
      for (int j = 0; j < n; j += kChunkPoints) {
        const int cnt = std::min(kChunkPoints, n - j);
        shape::addResponses(base, off + j, cnt, w, acc);
        const int done = j + cnt;
        if (done == n) break;
        const double bound = ((1 - g) * (n * thr - n + done) + g * thr * done) * kResponseMax;
        if (bound <= 0) continue;
        std::uint16_t best = 0;
        for (int x = 0; x < w; ++x) best = std::max(best, acc[x]);
        if (best < bound) {
          alive = false;
          break;
        }
      }
      item.alive[y % 3] = alive;
      if (alive) std::copy(acc, acc + w, item.ring.data() + static_cast<std::size_t>(y % 3) * w);
      if (y > 0) peaksOf(y - 1);
    }
    item.alive[b.h % 3] = 0;
    peaksOf(b.h - 1);
  }
}

// Unit gradient direction of img (Sobel 3x3, replicated border; 0 where the gradient is weaker
// than minC gray levels/px) over rect r, into u and v (CV_32F, img's size): the border columns
// here, the rest vectorised (shape::unitGradientRow). Written out rather than cv::Sobel: the
// tiles are small, and this is one pass with no temporary.
void unitGradient(const cv::Mat& img, cv::Rect r, float minC, cv::Mat& u, cv::Mat& v) {
  const int w = img.cols, h = img.rows;
  const float thr2 = 64.0f * minC * minC;  // Sobel sums are 8 x gray levels/px
  for (int y = r.y; y < r.y + r.height; ++y) {
    const std::uint8_t* a = img.ptr<std::uint8_t>(std::max(y - 1, 0));
    const std::uint8_t* b = img.ptr<std::uint8_t>(y);
    const std::uint8_t* c = img.ptr<std::uint8_t>(std::min(y + 1, h - 1));
    float* pu = u.ptr<float>(y);
    float* pv = v.ptr<float>(y);
    auto one = [&](int x, int xm, int xp) {
      const float gx = static_cast<float>((a[xp] - a[xm]) + 2 * (b[xp] - b[xm]) + (c[xp] - c[xm]));
      const float gy = static_cast<float>((c[xm] + 2 * c[x] + c[xp]) - (a[xm] + 2 * a[x] + a[xp]));
      const float m2 = gx * gx + gy * gy;
      const float k = m2 >= thr2 ? 1.0f / std::sqrt(std::max(m2, 1.0f)) : 0.0f;
      pu[x] = gx * k, pv[x] = gy * k;
    };
    int x0 = r.x, x1 = r.x + r.width;
    if (x0 == 0) one(0, 0, std::min(1, w - 1)), x0 = 1;
    const bool last = x1 == w && x1 > x0;
    if (last) --x1;
    if (x1 > x0) shape::unitGradientRow(a, b, c, pu, pv, x0, x1, thr2);
    if (last) one(w - 1, w - 2, w - 1);
  }
}

cv::Rect ShapeLocator::windowAt(int level, const Candidate& c, double extra) const {
  const double radius = m_.levels[0].radius * std::ldexp(1.0, -level) * (c.scale + (scaleSearch_ ? 2 * scaleStep(level) : 0));
  const int r = static_cast<int>(std::ceil(radius + extra)) + 2;
  return cv::Rect(cvRound(c.x) - r, cvRound(c.y) - r, 2 * r + 1, 2 * r + 1) & cv::Rect(0, 0, pyr_[level].cols, pyr_[level].rows);
}

void ShapeLocator::needTiles(int level, cv::Rect r) {
  if (r.empty()) return;
  std::vector<std::uint32_t>& stamp = tileStamp_[level];
  const int tx = tilesX_[level];
  for (int ty = r.y / kTile; ty <= (r.y + r.height - 1) / kTile; ++ty)
    for (int t = r.x / kTile; t <= (r.x + r.width - 1) / kTile; ++t) {
      const int i = ty * tx + t;
      if (stamp[i] == serial_) continue;
      stamp[i] = serial_;  // marked: computed by computeTiles before anyone reads it
      tileTodo_.push_back(i);
    }
}

void ShapeLocator::computeTiles(int level) {
  const cv::Mat& img = pyr_[level];
  const int tx = tilesX_[level];
  const float minC = static_cast<float>(p_.minContrast);
  cv::Mat& u = nx_[level];
  cv::Mat& v = ny_[level];
  auto tile = [&](int k) {
    const int i = tileTodo_[k];
    const cv::Rect r = cv::Rect((i % tx) * kTile, (i / tx) * kTile, kTile, kTile) & cv::Rect(0, 0, img.cols, img.rows);
    unitGradient(img, r, minC, u, v);
  };
  const int n = static_cast<int>(tileTodo_.size());
  if (p_.workers > 1 && n >= 8) {
    cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& rg) {
      for (int k = rg.start; k < rg.end; ++k) tile(k);
    }, std::min(n, 4 * p_.workers));
  } else {
    for (int k = 0; k < n; ++k) tile(k);
  }
  tileTodo_.clear();
}

template <class Fn>
void ShapeLocator::forEach(int n, const Fn& fn) const {
  if (p_.workers > 1 && n > 1) {
    cv::parallel_for_(cv::Range(0, n), [&](const cv::Range& rg) {
      for (int i = rg.start; i < rg.end; ++i) fn(i);
    }, n);
  } else {
    for (int i = 0; i < n; ++i) fn(i);
  }
}

// The smoothed level-0 gradient around c for the refinement (sigma 1 px, like the model's).
void ShapeLocator::smoothGradients(const Candidate& c) {
  const cv::Mat& img = pyr_[0];
  const int r = static_cast<int>(std::ceil(m_.levels[0].radius * c.scale * 1.01 + (graspRegionPts_.empty() ? 0 : p_.regionShiftPx))) + 8;
  const cv::Rect full(0, 0, img.cols, img.rows);
  const cv::Rect wide = cv::Rect(cvRound(c.x) - r, cvRound(c.y) - r, 2 * r + 1, 2 * r + 1) & full;
  if (wide.empty()) return;
  cv::Mat f = f32_(wide), b = blur_(wide), sx = sgx_(wide), sy = sgy_(wide);
  img(wide).convertTo(f, CV_32F);
  cv::GaussianBlur(f, b, cv::Size(7, 7), 1.0, 1.0, kBorderFlags);
  cv::Sobel(b, sx, CV_32F, 1, 0, 3, 1.0 / 8, 0, kBorderFlags);
  cv::Sobel(b, sy, CV_32F, 0, 1, 3, 1.0 / 8, 0, kBorderFlags);
}

// The model of search level `level` (level 0: the template's full-resolution points, for the
// most exact positions; above: the template level whose detail matches, Model::templateLevel)
// rotated by phi and scaled by `scale`, in that level's px.
void ShapeLocator::rotateModel(Rotated& r, int level, double phi, double scale) const {
  const int tl = level == 0 ? 0 : m_.templateLevel(level, scale);
  const LevelModel& lm = m_.levels[tl];
  const float f = static_cast<float>(scale * std::ldexp(1.0, tl - level));
  const float c = static_cast<float>(std::cos(phi)), s = static_cast<float>(std::sin(phi));
  r.count = lm.size();
  const int step = static_cast<int>(nx_[level].step1());
  int x0 = 0, x1 = 0, y0 = 0, y1 = 0;
  for (int k = 0; k < r.count; ++k) {
    r.rx[k] = f * (c * lm.x[k] - s * lm.y[k]);
    r.ry[k] = f * (s * lm.x[k] + c * lm.y[k]);
    r.ix[k] = cvRound(r.rx[k]);
    r.iy[k] = cvRound(r.ry[k]);
    r.lin[k] = r.iy[k] * step + r.ix[k];
    x0 = std::min(x0, r.ix[k]), x1 = std::max(x1, r.ix[k]), y0 = std::min(y0, r.iy[k]), y1 = std::max(y1, r.iy[k]);
    r.nx[k] = c * lm.nx[k] - s * lm.ny[k];
    r.ny[k] = s * lm.nx[k] + c * lm.ny[k];
  }
  r.box = cv::Rect(x0, y0, x1 - x0 + 1, y1 - y0 + 1);
}

// Score of the rotated model (rotateModel) with its origin at integer (x, y) of `level`
// (Steger 2002, eqs. 3-5).
double ShapeLocator::scoreAt(const Rotated& r, int level, int x, int y, int& sign) const {
  const cv::Mat& u = nx_[level];
  const cv::Mat& v = ny_[level];
  const bool absLocal = p_.polarity == ShapePolarity::IgnoreLocal;
  double sum = 0;
  if (x + r.box.x >= 0 && y + r.box.y >= 0 && x + r.box.x + r.box.width <= u.cols &&
      y + r.box.y + r.box.height <= u.rows) {
    // Inside: no bounds checks, one linear offset per point.
    const float* pu = u.ptr<float>(y) + x;
    const float* pv = v.ptr<float>(y) + x;
    const float* mx = r.nx.data();
    const float* my = r.ny.data();
    const int* lin = r.lin.data();
    float acc = 0;
    if (absLocal) {
      for (int k = 0; k < r.count; ++k) acc += std::abs(mx[k] * pu[lin[k]] + my[k] * pv[lin[k]]);
    } else {
      for (int k = 0; k < r.count; ++k) acc += mx[k] * pu[lin[k]] + my[k] * pv[lin[k]];
    }
    sum = acc;
  } else {
    for (int k = 0; k < r.count; ++k) {
      const int xx = x + r.ix[k], yy = y + r.iy[k];
      if (xx < 0 || yy < 0 || xx >= u.cols || yy >= u.rows) continue;
      const float d = r.nx[k] * u.ptr<float>(yy)[xx] + r.ny[k] * v.ptr<float>(yy)[xx];
      sum += absLocal ? std::abs(d) : d;
    }
  }
  double score = sum / r.count;
  sign = score < 0 ? -1 : 1;
  if (p_.polarity == ShapePolarity::IgnoreGlobal) score = std::abs(score);
  return score;
}

void ShapeLocator::bestAround(const Rotated& r, int level, int x0, int y0, int rad, double phi, double scale, Candidate& best) const {
  for (int dy = -rad; dy <= rad; ++dy)
    for (int dx = -rad; dx <= rad; ++dx) {
      int sign = 1;
      const double s = scoreAt(r, level, x0 + dx, y0 + dy, sign);
      if (s > best.score) {
        best.x = x0 + dx, best.y = y0 + dy, best.phi = phi, best.scale = scale, best.score = s, best.sign = sign;
      }
    }
}

void ShapeLocator::climb(Rotated& r, int level, Candidate& best, int rounds) const {
  for (int it = 0; it < rounds; ++it) {
    const Candidate at = best;
    const double step = angleStep(level, at.scale);
    for (int ka = -1; ka <= 1; ++ka) {
      rotateModel(r, level, at.phi + ka * step, at.scale);
      bestAround(r, level, cvRound(at.x), cvRound(at.y), 1, at.phi + ka * step, at.scale, best);
    }
    if (best.x == at.x && best.y == at.y && best.phi == at.phi) break;
  }
}

// One level down: the position doubles; search around it in position, angle and scale. From
// a top level (quantised responses, model points rounded to its pixels): +-2 px and as many
// of this level's angle and scale steps as the top's step spans; below: +-1 px and +-1 step
// (the level above found the peak to half its step, one step here), recentred while the best
// moves. Coordinate-wise: position and angle, then scale, then position and angle again.
bool ShapeLocator::trackDown(Rotated& r, Candidate& c, double thr) const {
  const int level = c.level - 1;
  const double step = angleStep(level, c.scale);
  Candidate best = c;
  best.level = level, best.x = 2 * c.x, best.y = 2 * c.y, best.score = -2, best.fromTop = false;
  if (c.fromTop) {
    const int kAngles = std::max(1, static_cast<int>(std::ceil(c.angleStep / step - 1e-9)));
    const int x0 = cvRound(best.x), y0 = cvRound(best.y);
    for (int ka = -kAngles; ka <= kAngles; ++ka) {
      rotateModel(r, level, c.phi + ka * step, c.scale);
      bestAround(r, level, x0, y0, 2, c.phi + ka * step, c.scale, best);
    }
    climb(r, level, best, 1);
  } else {
    climb(r, level, best, 3);
  }
  if (scaleSearch_) {
    const double sStep = scaleStep(level);
    const int kScales = c.fromTop ? std::max(1, static_cast<int>(std::ceil(c.scaleStep / sStep - 1e-9))) : 1;
    const Candidate at = best;
    for (int ks = -kScales; ks <= kScales; ++ks) {
      const double sc = at.scale + ks * sStep;
      if (ks == 0 || sc < taught_.scaleMin - sStep || sc > taught_.scaleMax + sStep) continue;
      rotateModel(r, level, at.phi, sc);
      bestAround(r, level, cvRound(at.x), cvRound(at.y), 1, at.phi, sc, best);
    }
    if (best.scale != at.scale) climb(r, level, best, 2);
    best.scaleStep = sStep;
  }
  best.angleStep = angleStep(level, best.scale);
  c = best;
  return c.score >= thr;
}

// Parabola through the scores at +-1 px, +-1 angle step (and +-1 scale step) around the
// integer peak, per axis (sub-pixel peak interpolation, docs/shape-matcher.md; the
// least-squares refinement follows). c: at level 0, near the peak (hill-climbed first).
void ShapeLocator::interpolatePeak(Rotated& r, Candidate& c) const {
  const double sStep = scaleSearch_ ? scaleStep(0) : 0.0;
  // Hill-climb first so the peak is interior.
  for (int it = 0; it < 6; ++it) {
    bool moved = false;
    const double step = angleStep(0, c.scale);
    for (const double dphi : {-step, step}) {
      rotateModel(r, 0, c.phi + dphi, c.scale);
      int sign = 1;
      const double s = scoreAt(r, 0, cvRound(c.x), cvRound(c.y), sign);
      if (s > c.score) c.phi += dphi, c.score = s, moved = true;
    }
    if (scaleSearch_) {
      for (const double ds : {-sStep, sStep}) {
        rotateModel(r, 0, c.phi, c.scale + ds);
        int sign = 1;
        const double s = scoreAt(r, 0, cvRound(c.x), cvRound(c.y), sign);
        if (s > c.score) c.scale += ds, c.score = s, moved = true;
      }
    }
    rotateModel(r, 0, c.phi, c.scale);
    const int x0 = cvRound(c.x), y0 = cvRound(c.y);
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        int sign = 1;
        const double s = scoreAt(r, 0, x0 + dx, y0 + dy, sign);
        if (s > c.score + 1e-12) c.x = x0 + dx, c.y = y0 + dy, c.score = s, moved = true;
      }
    if (!moved) break;
  }
  auto vertex = [](double sm, double s0, double sp) {
    const double den = sm - 2 * s0 + sp;
    return den < 0 ? std::clamp(0.5 * (sm - sp) / den, -0.5, 0.5) : 0.0;
  };
  int sign = 1;
  const double step = angleStep(0, c.scale);
  rotateModel(r, 0, c.phi, c.scale);
  const int cx = cvRound(c.x), cy = cvRound(c.y);
  const double s0 = scoreAt(r, 0, cx, cy, sign);
  const double ox = vertex(scoreAt(r, 0, cx - 1, cy, sign), s0, scoreAt(r, 0, cx + 1, cy, sign));
  const double oy = vertex(scoreAt(r, 0, cx, cy - 1, sign), s0, scoreAt(r, 0, cx, cy + 1, sign));
  rotateModel(r, 0, c.phi - step, c.scale);
  const double sm = scoreAt(r, 0, cx, cy, sign);
  rotateModel(r, 0, c.phi + step, c.scale);
  const double sp = scoreAt(r, 0, cx, cy, sign);
  const double oa = vertex(sm, s0, sp);
  double os = 0;
  if (scaleSearch_) {
    rotateModel(r, 0, c.phi, c.scale - sStep);
    const double ssm = scoreAt(r, 0, cx, cy, sign);
    rotateModel(r, 0, c.phi, c.scale + sStep);
    const double ssp = scoreAt(r, 0, cx, cy, sign);
    os = vertex(ssm, s0, ssp);
  }
  c.x = cx + ox, c.y = cy + oy, c.phi += oa * step, c.scale += os * sStep;
  rotateModel(r, 0, c.phi, c.scale);
  c.score = scoreAt(r, 0, cx, cy, c.sign);
}

// Least squares on point-to-tangent distances (Gauss-Newton over (tx, ty, phi), and the scale
// s with a scale range): each model point, placed by the current pose, looks along its normal
// for the sub-pixel image edge (shape::edgeAlongNormal); the residual is that signed
// distance, r_i = n_i . (e_i - q_i), with q_i = s R(phi) p_i the placed model point, and
// moving the pose by (dtx, dty, dphi, ds) changes it by
// -n_i . (dtx - dphi q_iy, dty + dphi q_ix) - ds n_i . q_i / s. Tukey weights drop occluded
// and cluttered points.
void ShapeLocator::refine(Rotated& r, Candidate& c) const {
  const LevelModel& lm = m_.levels[0];
  const bool absLocal = p_.polarity == ShapePolarity::IgnoreLocal;
  const double sign = c.sign;
  double tukey = 2.0;
  for (int it = 0; it < 6; ++it) {
    rotateModel(r, 0, c.phi, c.scale);
    Eigen::Matrix4d a = Eigen::Matrix4d::Zero();
    Eigen::Vector4d b = Eigen::Vector4d::Zero();
    int used = 0;
    for (int k = 0; k < lm.size(); ++k) {
      const double qx = r.rx[k], qy = r.ry[k], nx = r.nx[k], ny = r.ny[k];
      double t = 0, mag = 0;
      if (!shape::edgeAlongNormal(sgx_, sgy_, c.x + qx, c.y + qy, nx, ny, 2.0, sign, absLocal, p_.minContrast, t, mag))
        continue;
      if (std::abs(t) >= tukey) continue;
      const double u = t / tukey;
      // Tukey's biweight times the point's share of outline length: a digital edge has
      // max(|nx|, |ny|) points per px of length, so diagonal edges would otherwise weigh up to
      // 1.4x more and any bias common to all edges would become a translation.
      const double w = (1 - u * u) * (1 - u * u) / std::max(std::abs(lm.nx[k]), std::abs(lm.ny[k]));
      const Eigen::Vector4d j(nx, ny, -nx * qy + ny * qx, (nx * qx + ny * qy) / c.scale);
      a += w * j * j.transpose();
      b += w * j * t;
      ++used;
    }
    if (used < 8) return;
    Eigen::Vector4d d = Eigen::Vector4d::Zero();
    if (scaleSearch_) {
      d = a.ldlt().solve(b);
    } else {
      d.head<3>() = a.topLeftCorner<3, 3>().ldlt().solve(b.head<3>());
    }
    if (!d.allFinite()) return;
    c.x += d(0), c.y += d(1), c.phi += d(2), c.scale += d(3);
    tukey = 1.0;
    const double rim = lm.radius * c.scale;
    if (std::abs(d(0)) < 1e-4 && std::abs(d(1)) < 1e-4 && std::abs(d(2)) * rim < 1e-4 && std::abs(d(3)) * lm.radius < 1e-4) break;
  }
}

// Height-aware grasp (paper 000's projection difference, Sec. I): a raised region of the part
// shows shifted radially against the base by up to tens of px, so after the rigid fit the
// grasp point's region looks for its own translation, rotation shared: an exhaustive search
// of its gradient-direction score over +-regionShiftPx (2 px steps, then 1 px), then least
// squares on its point-to-tangent distances for (tx, ty) only. (tx, ty): the model origin's
// position for that region, px of level 0; unchanged when the region is not found.
void ShapeLocator::settleGraspRegion(Rotated& r, const Candidate& c, double& tx, double& ty) const {
  tx = c.x, ty = c.y;
  if (graspRegionPts_.empty()) return;
  rotateModel(r, 0, c.phi, c.scale);
  const cv::Mat& u = nx_[0];
  const cv::Mat& v = ny_[0];
  const int n = static_cast<int>(graspRegionPts_.size());
  auto score = [&](int dx, int dy) {
    double sum = 0;
    for (const int k : graspRegionPts_) {
      const int xx = cvRound(c.x) + dx + r.ix[k], yy = cvRound(c.y) + dy + r.iy[k];
      if (xx < 0 || yy < 0 || xx >= u.cols || yy >= u.rows) continue;
      const float d = r.nx[k] * u.ptr<float>(yy)[xx] + r.ny[k] * v.ptr<float>(yy)[xx];
      sum += p_.polarity == ShapePolarity::IgnoreLocal ? std::abs(d) : c.sign * d;
    }
    return sum / n;
  };
  const int range = static_cast<int>(std::ceil(p_.regionShiftPx));
  double best = -2;
  int bx = 0, by = 0;
  for (int dy = -range; dy <= range; dy += 2)
    for (int dx = -range; dx <= range; dx += 2)
      if (const double s = score(dx, dy); s > best) best = s, bx = dx, by = dy;
  const int cx = bx, cy = by;
  for (int dy = -1; dy <= 1; ++dy)
    for (int dx = -1; dx <= 1; ++dx)
      if (const double s = score(cx + dx, cy + dy); s > best) best = s, bx = cx + dx, by = cy + dy;
  if (best < taught_.minScore) return;  // the region is not there: keep the rigid pose
  // Where the rigid pose fits the region about as well, stay: a shifted look-alike (a second
  // hole, a straight edge slid along itself) must be clearly better to win.
  if (score(0, 0) >= best - 0.05) bx = 0, by = 0;
  double x = cvRound(c.x) + bx, y = cvRound(c.y) + by;
  double tukey = 2.0;
  for (int it = 0; it < 6; ++it) {
    Eigen::Matrix2d a = Eigen::Matrix2d::Zero();
    Eigen::Vector2d b = Eigen::Vector2d::Zero();
    int used = 0;
    for (const int k : graspRegionPts_) {
      double t = 0, mag = 0;
      if (!shape::edgeAlongNormal(sgx_, sgy_, x + r.rx[k], y + r.ry[k], r.nx[k], r.ny[k], 2.0, c.sign,
                                  p_.polarity == ShapePolarity::IgnoreLocal, p_.minContrast, t, mag) ||
          std::abs(t) >= tukey)
        continue;
      const double q = t / tukey;
      const double w = (1 - q * q) * (1 - q * q);
      const Eigen::Vector2d j(r.nx[k], r.ny[k]);
      a += w * j * j.transpose();
      b += w * j * t;
      ++used;
    }
    if (used < 8) break;
    // A straight region pins only its normal direction: a small ridge keeps the other one.
    a += 1e-3 * a.trace() * Eigen::Matrix2d::Identity();
    const Eigen::Vector2d d = a.ldlt().solve(b);
    if (!d.allFinite()) break;
    x += d(0), y += d(1);
    tukey = 1.0;
    if (d.norm() < 1e-4) break;
  }
  tx = x, ty = y;
}

bool ShapeLocator::overlap(const Candidate& a, const Candidate& b) const {
  const double fa = std::ldexp(1.0, a.level), fb = std::ldexp(1.0, b.level);
  const double q = std::hypot(a.x * fa - b.x * fb, a.y * fa - b.y * fb) / (eqRadius_ * (a.scale + b.scale));
  const double f = q < 1 ? 2 / std::numbers::pi * (std::acos(q) - q * std::sqrt(1 - q * q)) : 0.0;
  return f > p_.maxOverlap;
}

void ShapeLocator::pruneBeaten(std::vector<Candidate>& cands, int level) const {
  std::sort(cands.begin(), cands.end(), [](const Candidate& l, const Candidate& r) { return l.score > r.score; });
  std::size_t out = 0;
  for (std::size_t i = 0; i < cands.size(); ++i) {
    bool beaten = false;
    if (cands[i].level == level)
      for (std::size_t j = 0; j < out && !beaten; ++j)
        beaten = cands[j].level == level && cands[j].score - cands[i].score >= kBeatenMargin && overlap(cands[i], cands[j]);
    if (!beaten) cands[out++] = cands[i];
  }
  cands.resize(out);
}

// Greedy non-maximum suppression: a candidate within distPx (px of level 0, times 2^level of
// the better one) and angle of a better one goes (whatever its scale: one part has one scale).
void ShapeLocator::suppress(std::vector<Candidate>& cands, double distPx, double angle, std::size_t keep) const {
  std::sort(cands.begin(), cands.end(), [](const Candidate& l, const Candidate& r) { return l.score > r.score; });
  std::size_t out = 0;
  for (std::size_t i = 0; i < cands.size() && out < keep; ++i) {
    bool dup = false;
    const double fi = std::ldexp(1.0, cands[i].level);
    for (std::size_t j = 0; j < out && !dup; ++j) {
      const double fj = std::ldexp(1.0, cands[j].level);
      dup = std::hypot(cands[i].x * fi - cands[j].x * fj, cands[i].y * fi - cands[j].y * fj) <= distPx * fj &&
            (angle <= 0 || angleDist(cands[i].phi, cands[j].phi) <= angle);
    }
    if (!dup) cands[out++] = cands[i];
  }
  cands.resize(out);
}

Result<LocateOutput> ShapeLocator::locate(const cv::Mat& gray) {
  if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "shape: expected a non-empty 8-bit gray image");
  StageClock clock(times_);
  cv::Rect roi(0, 0, gray.cols, gray.rows);
  if (!taught_.searchRoi.empty())
    roi &= cv::Rect(taught_.searchRoi.x, taught_.searchRoi.y, taught_.searchRoi.width, taught_.searchRoi.height);
  LocateOutput out;
  const int minSide = 1 << maxTop_;
  if (roi.width < 2 * minSide || roi.height < 2 * minSide) return out;
  prepare(roi.size());
  if (++serial_ == 0) {  // 2^32 calls: start the tile stamps again
    for (auto& stamps : tileStamp_) std::fill(stamps.begin(), stamps.end(), 0);
    serial_ = 1;
  }

  pyr_[0] = gray(roi);
  for (int l = 1; l <= maxTop_; ++l) cv::pyrDown(pyr_[l - 1], pyr_[l], pyr_[l].size(), cv::BORDER_REPLICATE);
  clock.lap(ShapeStageTimes::Pyramid);

  for (Band& b : bands_) responseMaps(b);
  clock.lap(ShapeStageTimes::TopGradient);

  const double minScore = taught_.minScore;
  const double coarseThr = minScore * kCoarseSlack;
  const int items = static_cast<int>(items_.size());
  for (WorkItem& it : items_) it.found.clear();
  if (p_.workers > 1) {
    // Many small items, taken as workers free up (TBB): a busy second core only delays the
    // items it took, so two workers are never slower than one by more than one item.
    cv::parallel_for_(cv::Range(0, items), [&](const cv::Range& r) {
      for (int i = r.start; i < r.end; ++i) searchTop(items_[i], coarseThr);
    }, items);
  } else {
    for (WorkItem& it : items_) searchTop(it, coarseThr);
  }
  cands_.clear();
  for (const WorkItem& it : items_) cands_.insert(cands_.end(), it.found.begin(), it.found.end());
  const std::size_t keep = static_cast<std::size_t>(4 * taught_.maxParts + 4);
  suppress(cands_, 1.5, 1.5 * maxTopStep_, keep);
  clock.lap(ShapeStageTimes::TopSearch);

  // Down to level 1, breadth first (a candidate of a band whose top is level 0 or 1 is there
  // already): at every level the gradient tiles all candidates read are computed once, the
  // candidates are searched in parallel, then duplicates go and so do candidates clearly
  // beaten by an overlapping one (pruneBeaten).
  for (int l = maxTop_ - 1; l >= 1; --l) {
    next_.clear();  // the candidates to track from l + 1
    std::size_t stay = 0;
    for (const Candidate& c : cands_) {
      if (c.level == l + 1) {
        next_.push_back(c);
      } else {
        cands_[stay++] = c;
      }
    }
    cands_.resize(stay);
    if (next_.empty()) continue;
    for (const Candidate& c : next_) {
      Candidate at = c;
      at.x *= 2, at.y *= 2, at.level = l;
      needTiles(l, windowAt(l, at, 10.0));  // +-2 px, climbs of <= 5 px, 2 scale steps
    }
    computeTiles(l);
    kept_.assign(next_.size(), 0);
    forEach(static_cast<int>(next_.size()), [&](int i) { kept_[i] = trackDown(scratch_[i], next_[i], coarseThr); });
    for (std::size_t i = 0; i < next_.size(); ++i)
      if (kept_[i]) cands_.push_back(next_[i]);
    suppress(cands_, 1.5, 0.6 * angleStep(l, taught_.scaleMax), keep);
    pruneBeaten(cands_, l);
  }
  // Level 0: from twice the level-1 pose, hill-climb and interpolate (interpolatePeak).
  const double regionExtra = graspRegionPts_.empty() || !p_.refine ? 0.0 : p_.regionShiftPx;
  for (Candidate& c : cands_) {
    if (c.level == 1) c.x *= 2, c.y *= 2, c.level = 0;
    needTiles(0, windowAt(0, c, 14.0 + regionExtra));  // hill-climb <= 6 px and 6 scale steps, +-1 px
  }
  computeTiles(0);
  kept_.assign(cands_.size(), 0);
  forEach(static_cast<int>(cands_.size()), [&](int i) {
    Candidate& c = cands_[i];
    Rotated& r = scratch_[i];
    rotateModel(r, 0, c.phi, c.scale);
    int sign = 1;
    c.score = scoreAt(r, 0, cvRound(c.x), cvRound(c.y), sign);
    interpolatePeak(r, c);
    kept_[i] = c.score >= minScore;
  });
  next_.clear();
  for (std::size_t i = 0; i < cands_.size(); ++i)
    if (kept_[i]) next_.push_back(cands_[i]);
  cands_.swap(next_);
  clock.lap(ShapeStageTimes::Track);

  // Full resolution, best first: overlap control, then the sub-pixel pose, until maxParts.
  // Only parts that make the output pay for the refinement.
  std::sort(cands_.begin(), cands_.end(), [](const Candidate& l, const Candidate& r) { return l.score > r.score; });
  next_.clear();
  auto overlapsKept = [&](const Candidate& c) {
    for (const Candidate& k : next_) {
      const double q = std::hypot(c.x - k.x, c.y - k.y) / (eqRadius_ * (c.scale + k.scale));
      const double f = q < 1 ? 2 / std::numbers::pi * (std::acos(q) - q * std::sqrt(1 - q * q)) : 0.0;
      if (f > p_.maxOverlap) return true;
    }
    return false;
  };
  for (Candidate c : cands_) {
    if (static_cast<int>(next_.size()) >= taught_.maxParts) break;
    if (overlapsKept(c)) continue;
    Rotated& r = scratch_[0];
    if (p_.refine) {
      smoothGradients(c);
      refine(r, c);
      // The score of the refined pose (the model at its angle and scale, at the nearest
      // pixel), not of the integer peak interpolatePeak started from: a function of the pose
      // found rather than of the path to it (which min_score itself changes: replay_cli_test).
      rotateModel(r, 0, c.phi, c.scale);
      c.score = scoreAt(r, 0, cvRound(c.x), cvRound(c.y), c.sign);
    }
    double tx = c.x, ty = c.y;
    if (p_.refine) settleGraspRegion(r, c, tx, ty);  // scores on the level-0 tiles computed above
    if (c.score < minScore || overlapsKept(c)) continue;
    const double angleDeg = normaliseDeg(-c.phi * 180 / std::numbers::pi);
    const double tol = angleStep(0, c.scale) * 180 / std::numbers::pi;
    if (!fullCircle_ && (angleDeg < taught_.angleMinDeg - tol || angleDeg > taught_.angleMaxDeg + tol)) continue;
    const double sTol = scaleStep(0);
    if (scaleSearch_ && (c.scale < taught_.scaleMin - sTol || c.scale > taught_.scaleMax + sTol)) continue;
    next_.push_back(c);
    const double cs = std::cos(c.phi), sn = std::sin(c.phi);
    const double gx = c.scale * (taught_.grasp.u - m_.origin.u), gy = c.scale * (taught_.grasp.v - m_.origin.v);
    Detection d;
    d.u = roi.x + tx + cs * gx - sn * gy;
    d.v = roi.y + ty + sn * gx + cs * gy;
    d.angleDeg = angleDeg;
    d.scale = c.scale;
    d.score = c.score;
    out.parts.push_back(d);
  }
  clock.lap(ShapeStageTimes::Refine);
  return out;
}

}  // namespace

Result<ShapeParams> parseShapeParams(const TaughtTemplate& taught) {
  // "polarity" is a word, which ParamReader does not read: take it out, check it here.
  std::map<std::string, std::string> numeric = taught.params;
  numeric.erase("polarity");
  ParamReader r("shape", numeric, taught.paramSources);
  ShapeParams p;
  p.levels = r.integer("levels", p.levels, 0, 7);
  p.modelContrast = r.number("model_contrast", p.modelContrast, 1, 255);
  p.minContrast = r.number("min_contrast", p.minContrast, 0, 255);
  p.greediness = r.number("greediness", p.greediness, 0, 1);
  p.angleStepDeg = r.number("angle_step_deg", p.angleStepDeg, 0, 10);
  p.maxPoints = r.integer("max_points", p.maxPoints, 50, 20000);
  p.maxOverlap = r.number("max_overlap", p.maxOverlap, 0, 1);
  p.refine = r.flag("refine", p.refine);
  p.workers = r.integer("workers", p.workers, 1, 16);
  p.regionShiftPx = r.number("region_shift_px", p.regionShiftPx, 0, 200);
  if (auto ok = r.finish(); !ok) return std::unexpected(ok.error());
  if (const auto it = taught.params.find("polarity"); it != taught.params.end()) {
    if (it->second == "use") {
      p.polarity = ShapePolarity::Use;
    } else if (it->second == "ignore_global") {
      p.polarity = ShapePolarity::IgnoreGlobal;
    } else if (it->second == "ignore_local") {
      p.polarity = ShapePolarity::IgnoreLocal;
    } else {
      return fail(Status::BadArgument,
                  fmt::format("shape: parameter 'polarity': expected use, ignore_global or ignore_local, got '{}'{}",
                              it->second, r.whereWritten("polarity")));
    }
  }
  if (taught.minScore < 0 || taught.minScore > 1)
    return fail(Status::BadArgument, fmt::format("shape: min_score must be in [0, 1], got {}", taught.minScore));
  if (!(taught.scaleMin <= taught.scaleMax) || taught.scaleMin < kMinPartScale || taught.scaleMax > kMaxPartScale)
    return fail(Status::BadArgument, fmt::format("shape: scale range [{}, {}] is not a range within [{}, {}]", taught.scaleMin,
                                                 taught.scaleMax, kMinPartScale, kMaxPartScale));
  if (!(taught.angleMinDeg <= taught.angleMaxDeg) || taught.angleMinDeg < -360 || taught.angleMaxDeg > 360)
    return fail(Status::BadArgument, fmt::format("shape: angle range [{}, {}] deg is not a range within [-360, 360]",
                                                 taught.angleMinDeg, taught.angleMaxDeg));
  return p;
}

const char* ShapeStageTimes::name(int stage) {
  static const char* const kNames[kCount] = {"pyramid", "top gradient", "top search", "tracking", "refinement"};
  return stage >= 0 && stage < kCount ? kNames[stage] : "?";
}

const ShapeStageTimes* shapeStageTimes(const Locator& locator) {
  const auto* shape = dynamic_cast<const ShapeLocator*>(&locator);
  return shape ? &shape->stageTimes() : nullptr;
}

Result<std::unique_ptr<Locator>> makeShapeLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  auto params = parseShapeParams(taught);
  if (!params) return std::unexpected(params.error());
  auto model = shape::buildModel(templateGray, *params, taught.scaleMin);
  if (!model) return std::unexpected(model.error());
  return std::make_unique<ShapeLocator>(*params, std::move(*model), taught);
}

}  // namespace vgr::vision
