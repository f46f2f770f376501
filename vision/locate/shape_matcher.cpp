#include "vision/locate/shape_matcher.hpp"

#include <algorithm>
#include <cmath>
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

namespace vgr::vision {
namespace {

using shape::LevelModel;
using shape::Model;

constexpr int kChunk = 8;              // model points between early-termination checks
constexpr double kCoarseSlack = 0.85;  // coarse levels accept minScore * this (blur, rounding)
constexpr int kBorderFlags = cv::BORDER_REPLICATE | cv::BORDER_ISOLATED;

double angleDist(double a, double b) { return std::abs(std::remainder(a - b, 2 * std::numbers::pi)); }

// The hot loop of the top-level search: for kChunk model points, add each point's dot product
// with the image gradient direction to a row of positions. Contiguous in x, so it vectorises;
// target_clones builds an AVX2 copy next to the baseline (SSE2) one and picks at load time,
// because the project compiles for the baseline x86-64 (no -march flags).
__attribute__((target_clones("avx2", "default"))) void accumulateChunk(float* __restrict acc, int width,
                                                                      const float* const* gx, const float* const* gy,
                                                                      const float* mx, const float* my, int count,
                                                                      bool absolute) {
  for (int k = 0; k < count; ++k) {
    const float* __restrict a = gx[k];
    const float* __restrict b = gy[k];
    const float cx = mx[k], cy = my[k];
    if (absolute) {
      for (int i = 0; i < width; ++i) acc[i] += std::abs(cx * a[i] + cy * b[i]);
    } else {
      for (int i = 0; i < width; ++i) acc[i] += cx * a[i] + cy * b[i];
    }
  }
}

struct Candidate {
  double x = 0, y = 0;  // model origin, px of the current level (ROI coordinates)
  double phi = 0;       // rad, image rotation (x right, y down: clockwise as displayed)
  double score = 0;     // [-1, 1]
  int sign = 1;         // -1: inverted contrast (polarity ignore_global)
};

// A model rotated by one angle (top level), rounded to pixel offsets.
struct RotatedModel {
  double phi = 0;
  std::vector<int> dx, dy;
  std::vector<float> mx, my;
};

class ShapeLocator final : public Locator {
 public:
  ShapeLocator(ShapeParams params, Model model, const TaughtTemplate& taught)
      : p_(params), m_(std::move(model)), taught_(taught) {
    const int top = static_cast<int>(m_.levels.size()) - 1;
    const LevelModel& tm = m_.levels[top];
    // Angle grid of the top level, in image rotation phi = -angleDeg.
    const double lo = -taught.angleMaxDeg * std::numbers::pi / 180, hi = -taught.angleMinDeg * std::numbers::pi / 180;
    fullCircle_ = taught.angleMaxDeg - taught.angleMinDeg >= 360 - 1e-9;
    int n = 0;
    if (fullCircle_) {
      n = static_cast<int>(std::ceil(2 * std::numbers::pi / tm.angleStep));
      topStep_ = 2 * std::numbers::pi / n;
    } else {
      n = std::max(1, static_cast<int>(std::ceil((hi - lo) / tm.angleStep)) + 1);
      topStep_ = n > 1 ? (hi - lo) / (n - 1) : tm.angleStep;
    }
    for (int i = 0; i < n; ++i) {
      RotatedModel r;
      r.phi = fullCircle_ ? i * topStep_ : lo + i * topStep_;
      const double c = std::cos(r.phi), s = std::sin(r.phi);
      for (int k = 0; k < tm.size(); ++k) {
        r.dx.push_back(cvRound(c * tm.x[k] - s * tm.y[k]));
        r.dy.push_back(cvRound(s * tm.x[k] + c * tm.y[k]));
        r.mx.push_back(static_cast<float>(c * tm.nx[k] - s * tm.ny[k]));
        r.my.push_back(static_cast<float>(s * tm.nx[k] + c * tm.ny[k]));
      }
      rotated_.push_back(std::move(r));
    }
    // Equivalent circle of the part for overlap control: the level-0 points' bounding box.
    const LevelModel& m0 = m_.levels[0];
    const auto [x0, x1] = std::minmax_element(m0.x.begin(), m0.x.end());
    const auto [y0, y1] = std::minmax_element(m0.y.begin(), m0.y.end());
    eqRadius_ = std::sqrt((*x1 - *x0) * (*y1 - *y0) / std::numbers::pi);
    const std::size_t maxPts = m0.x.size();
    rx_.resize(maxPts), ry_.resize(maxPts), rnx_.resize(maxPts), rny_.resize(maxPts);
    ix_.resize(maxPts), iy_.resize(maxPts);
    workers_.resize(static_cast<std::size_t>(p_.workers));
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

 private:
  struct Worker {
    std::vector<float> map;
    std::vector<Candidate> found;
    std::vector<const float*> gxPtr, gyPtr;
  };

  void prepare(cv::Size roiSize);
  void searchTop(Worker& w, int first, int stride, double thr);
  void levelGradients(int level, const Candidate& c, double extra);
  void smoothGradients(const Candidate& c);
  double scoreAt(int level, int x, int y, int& sign) const;
  void rotateModel(int level, double phi);
  bool trackDown(int level, Candidate& c, double thr);
  void interpolatePeak(Candidate& c);
  void refine(Candidate& c);
  void suppress(std::vector<Candidate>& cands, double distPx, double angle, std::size_t keep) const;
  void settleGraspRegion(const Candidate& c, double& tx, double& ty);

  ShapeParams p_;
  Model m_;
  TaughtTemplate taught_;
  bool fullCircle_ = true;
  double topStep_ = 0;
  double eqRadius_ = 0;
  std::vector<RotatedModel> rotated_;

  // Per image size (prepare()).
  cv::Size roiSize_;
  std::vector<cv::Mat> pyr_;            // [0] = a view of the live image's ROI
  std::vector<cv::Mat> gx_, gy_;        // raw gradient per level (windows only below the top)
  std::vector<cv::Mat> nx_, ny_;        // unit gradient direction, 0 below minContrast
  cv::Mat f32_, blur_, sgx_, sgy_;      // level 0: smoothed image and its gradient (refinement)
  int topW_ = 0, topH_ = 0, pad_ = 0, stride_ = 0;
  std::vector<float> topX_, topY_;      // padded unit gradient of the top level
  std::vector<Worker> workers_;
  std::vector<Candidate> cands_, next_;
  // Current rotated model (lower levels).
  std::vector<float> rx_, ry_, rnx_, rny_;
  std::vector<int> ix_, iy_;
  int rotatedCount_ = 0;
  // Height-aware grasp: indices of the level-0 model points on the grasp point's region.
  std::vector<int> graspRegionPts_;
};

void ShapeLocator::prepare(cv::Size roiSize) {
  if (roiSize == roiSize_) return;
  roiSize_ = roiSize;
  const int levels = static_cast<int>(m_.levels.size());
  pyr_.assign(static_cast<std::size_t>(levels), cv::Mat());
  gx_.assign(pyr_.size(), cv::Mat()), gy_.assign(pyr_.size(), cv::Mat());
  nx_.assign(pyr_.size(), cv::Mat()), ny_.assign(pyr_.size(), cv::Mat());
  cv::Size s = roiSize;
  for (int l = 0; l < levels; ++l) {
    if (l > 0) {
      s = cv::Size((s.width + 1) / 2, (s.height + 1) / 2);
      pyr_[l].create(s, CV_8UC1);
    }
    gx_[l].create(s, CV_32F), gy_[l].create(s, CV_32F);
    nx_[l].create(s, CV_32F), ny_[l].create(s, CV_32F);
  }
  f32_.create(roiSize, CV_32F), blur_.create(roiSize, CV_32F);
  sgx_.create(roiSize, CV_32F), sgy_.create(roiSize, CV_32F);
  // Touch every page now: windows land anywhere, and first-touch page faults in the middle
  // of a search cost tens of ms on a 5 MP image.
  for (std::size_t l = 0; l < pyr_.size(); ++l) gx_[l] = 0.f, gy_[l] = 0.f, nx_[l] = 0.f, ny_[l] = 0.f;
  f32_ = 0.f, blur_ = 0.f, sgx_ = 0.f, sgy_ = 0.f;
  topW_ = s.width, topH_ = s.height;
  pad_ = static_cast<int>(std::ceil(m_.levels.back().radius)) + 2;
  stride_ = topW_ + 2 * pad_;
  topX_.assign(static_cast<std::size_t>(stride_) * (topH_ + 2 * pad_), 0.f);
  topY_.assign(topX_.size(), 0.f);
  for (Worker& w : workers_) {
    w.map.assign(static_cast<std::size_t>(topW_) * topH_, 0.f);
    w.found.clear();
    w.found.reserve(4096);
    w.gxPtr.resize(kChunk), w.gyPtr.resize(kChunk);
  }
  cands_.reserve(4096), next_.reserve(4096);
}

// Scores every top-level position for the angles first, first + stride, ... and collects
// the local maxima above thr. Early termination per row (Steger 2002, sec. 3.2): after j of n
// points a row is dropped when its best partial sum is below
// (1 - g) * (n thr - n + j) + g * thr * j, the safe bound for g = 0 (every remaining point
// could still add 1) and the greedy one for g = 1 (the remaining points add thr each).
void ShapeLocator::searchTop(Worker& w, int first, int stride, double thr) {
  const int n = m_.levels.back().size();
  const double g = p_.greediness;
  const bool absLocal = p_.polarity == ShapePolarity::IgnoreLocal;
  const bool absGlobal = p_.polarity == ShapePolarity::IgnoreGlobal;
  const float invN = 1.0f / static_cast<float>(n);
  for (int a = first; a < static_cast<int>(rotated_.size()); a += stride) {
    const RotatedModel& r = rotated_[a];
    for (int y = 0; y < topH_; ++y) {
      float* acc = w.map.data() + static_cast<std::size_t>(y) * topW_;
      std::fill(acc, acc + topW_, 0.f);
      bool dead = false;
      for (int j = 0; j < n && !dead; j += kChunk) {
        const int cnt = std::min(kChunk, n - j);
        for (int k = 0; k < cnt; ++k) {
          const std::size_t off = static_cast<std::size_t>(y + pad_ + r.dy[j + k]) * stride_ + pad_ + r.dx[j + k];
          w.gxPtr[k] = topX_.data() + off;
          w.gyPtr[k] = topY_.data() + off;
        }
        accumulateChunk(acc, topW_, w.gxPtr.data(), w.gyPtr.data(), r.mx.data() + j, r.my.data() + j, cnt, absLocal);
        const int done = j + cnt;
        if (done == n) break;
        const double bound = (1 - g) * (n * thr - n + done) + g * thr * done;
        float best = -1e30f;
        if (absGlobal) {
          for (int i = 0; i < topW_; ++i) best = std::max(best, std::abs(acc[i]));
        } else {
          for (int i = 0; i < topW_; ++i) best = std::max(best, acc[i]);
        }
        if (best < bound) dead = true;
      }
      if (dead) {
        std::fill(acc, acc + topW_, -2.f * n);
        continue;
      }
      for (int i = 0; i < topW_; ++i) acc[i] = (absGlobal ? std::abs(acc[i]) : acc[i]) * invN;
      // (ignore_global: the sign is not kept here; the next level's scoreAt() finds it.)
    }
    // Local maxima (8-neighbourhood) above thr.
    const float t = static_cast<float>(thr);
    for (int y = 0; y < topH_; ++y) {
      const float* row = w.map.data() + static_cast<std::size_t>(y) * topW_;
      for (int x = 0; x < topW_; ++x) {
        const float v = row[x];
        if (v < t) continue;
        bool peak = true;
        for (int dy = -1; dy <= 1 && peak; ++dy) {
          const int yy = y + dy;
          if (yy < 0 || yy >= topH_) continue;
          const float* rr = w.map.data() + static_cast<std::size_t>(yy) * topW_;
          for (int dx = -1; dx <= 1; ++dx) {
            const int xx = x + dx;
            if ((dx == 0 && dy == 0) || xx < 0 || xx >= topW_) continue;
            // Ties: the first in raster order wins.
            if (rr[xx] > v || (rr[xx] == v && (dy < 0 || (dy == 0 && dx < 0)))) {
              peak = false;
              break;
            }
          }
        }
        if (!peak) continue;
        if (w.found.size() == w.found.capacity()) {
          // Full: keep the better half (no reallocation on the hot path).
          std::nth_element(w.found.begin(), w.found.begin() + w.found.size() / 2, w.found.end(),
                           [](const Candidate& l, const Candidate& rr) { return l.score > rr.score; });
          w.found.resize(w.found.size() / 2);
        }
        w.found.push_back({double(x), double(y), r.phi, double(v), 1});
      }
    }
  }
}

// Gradients of `level` in a window around candidate c big enough for the model at any angle,
// the +-2 px search and `extra` px (the refinement's search along the normals).
void ShapeLocator::levelGradients(int level, const Candidate& c, double extra) {
  const LevelModel& lm = m_.levels[level];
  const cv::Mat& img = pyr_[level];
  const int r = static_cast<int>(std::ceil(lm.radius + 3 + extra)) + 2;
  const cv::Rect full(0, 0, img.cols, img.rows);
  const cv::Rect win = cv::Rect(cvRound(c.x) - r, cvRound(c.y) - r, 2 * r + 1, 2 * r + 1) & full;
  if (win.empty()) return;
  // A 1-px margin so that the Sobel kernel sees real neighbours; BORDER_ISOLATED keeps OpenCV
  // from reading outside the window (stale buffers).
  const cv::Rect outer = cv::Rect(win.x - 1, win.y - 1, win.width + 2, win.height + 2) & full;
  cv::Mat gxo = gx_[level](outer), gyo = gy_[level](outer);
  cv::Sobel(img(outer), gxo, CV_32F, 1, 0, 3, 1.0 / 8, 0, kBorderFlags);
  cv::Sobel(img(outer), gyo, CV_32F, 0, 1, 3, 1.0 / 8, 0, kBorderFlags);
  const float minC = static_cast<float>(p_.minContrast);
  for (int y = win.y; y < win.y + win.height; ++y) {
    const float* a = gx_[level].ptr<float>(y);
    const float* b = gy_[level].ptr<float>(y);
    float* u = nx_[level].ptr<float>(y);
    float* v = ny_[level].ptr<float>(y);
    for (int x = win.x; x < win.x + win.width; ++x) {
      const float m = std::sqrt(a[x] * a[x] + b[x] * b[x]);
      const float inv = m >= minC && m > 0 ? 1.0f / m : 0.0f;
      u[x] = a[x] * inv, v[x] = b[x] * inv;
    }
  }
}

// The smoothed level-0 gradient around c for the refinement (sigma 1 px, like the model's).
void ShapeLocator::smoothGradients(const Candidate& c) {
  const cv::Mat& img = pyr_[0];
  const int r = static_cast<int>(std::ceil(m_.levels[0].radius + (graspRegionPts_.empty() ? 0 : p_.regionShiftPx))) + 8;
  const cv::Rect full(0, 0, img.cols, img.rows);
  const cv::Rect wide = cv::Rect(cvRound(c.x) - r, cvRound(c.y) - r, 2 * r + 1, 2 * r + 1) & full;
  if (wide.empty()) return;
  cv::Mat f = f32_(wide), b = blur_(wide), sx = sgx_(wide), sy = sgy_(wide);
  img(wide).convertTo(f, CV_32F);
  cv::GaussianBlur(f, b, cv::Size(7, 7), 1.0, 1.0, kBorderFlags);
  cv::Sobel(b, sx, CV_32F, 1, 0, 3, 1.0 / 8, 0, kBorderFlags);
  cv::Sobel(b, sy, CV_32F, 0, 1, 3, 1.0 / 8, 0, kBorderFlags);
}

void ShapeLocator::rotateModel(int level, double phi) {
  const LevelModel& lm = m_.levels[level];
  const float c = static_cast<float>(std::cos(phi)), s = static_cast<float>(std::sin(phi));
  rotatedCount_ = lm.size();
  for (int k = 0; k < rotatedCount_; ++k) {
    rx_[k] = c * lm.x[k] - s * lm.y[k];
    ry_[k] = s * lm.x[k] + c * lm.y[k];
    ix_[k] = cvRound(rx_[k]);
    iy_[k] = cvRound(ry_[k]);
    rnx_[k] = c * lm.nx[k] - s * lm.ny[k];
    rny_[k] = s * lm.nx[k] + c * lm.ny[k];
  }
}

// Score of the rotated model (rotateModel) with its origin at integer (x, y) of `level`.
double ShapeLocator::scoreAt(int level, int x, int y, int& sign) const {
  const cv::Mat& u = nx_[level];
  const cv::Mat& v = ny_[level];
  const bool absLocal = p_.polarity == ShapePolarity::IgnoreLocal;
  double sum = 0;
  for (int k = 0; k < rotatedCount_; ++k) {
    const int xx = x + ix_[k], yy = y + iy_[k];
    if (xx < 0 || yy < 0 || xx >= u.cols || yy >= u.rows) continue;
    const float d = rnx_[k] * u.ptr<float>(yy)[xx] + rny_[k] * v.ptr<float>(yy)[xx];
    sum += absLocal ? std::abs(d) : d;
  }
  double score = sum / rotatedCount_;
  sign = score < 0 ? -1 : 1;
  if (p_.polarity == ShapePolarity::IgnoreGlobal) score = std::abs(score);
  return score;
}

// From level + 1 to `level`: the position doubles; search +-2 px and +-2 angle steps of
// this level (the coarser level's step is about twice this one's).
bool ShapeLocator::trackDown(int level, Candidate& c, double thr) {
  const LevelModel& lm = m_.levels[level];
  const double coarseStep = level + 1 == static_cast<int>(m_.levels.size()) - 1 ? topStep_ : m_.levels[level + 1].angleStep;
  const int kAngles = std::max(1, static_cast<int>(std::ceil(coarseStep / lm.angleStep)));
  Candidate best = c;
  best.x = 2 * c.x, best.y = 2 * c.y, best.score = -2;
  levelGradients(level, best, level > 0 ? 0.0 : graspRegionPts_.empty() ? 3.0 : 3.0 + p_.regionShiftPx);
  const int x0 = cvRound(best.x), y0 = cvRound(best.y);
  for (int ka = -kAngles; ka <= kAngles; ++ka) {
    const double phi = c.phi + ka * lm.angleStep;
    rotateModel(level, phi);
    for (int dy = -2; dy <= 2; ++dy)
      for (int dx = -2; dx <= 2; ++dx) {
        int sign = 1;
        const double s = scoreAt(level, x0 + dx, y0 + dy, sign);
        if (s > best.score) best = {double(x0 + dx), double(y0 + dy), phi, s, sign};
      }
  }
  c = best;
  return c.score >= thr;
}

// Parabola through the scores at +-1 px and +-1 angle step around the integer peak, per axis
// (sub-pixel peak interpolation, docs/shape-matcher.md; the least-squares refinement follows).
void ShapeLocator::interpolatePeak(Candidate& c) {
  const double step = m_.levels[0].angleStep;
  // Hill-climb first so the peak is interior.
  for (int it = 0; it < 4; ++it) {
    bool moved = false;
    for (const double dphi : {-step, step}) {
      rotateModel(0, c.phi + dphi);
      int sign = 1;
      const double s = scoreAt(0, cvRound(c.x), cvRound(c.y), sign);
      if (s > c.score) c.phi += dphi, c.score = s, moved = true;
    }
    rotateModel(0, c.phi);
    for (int dy = -1; dy <= 1; ++dy)
      for (int dx = -1; dx <= 1; ++dx) {
        int sign = 1;
        const double s = scoreAt(0, cvRound(c.x) + dx, cvRound(c.y) + dy, sign);
        if (s > c.score + 1e-12) c.x = cvRound(c.x) + dx, c.y = cvRound(c.y) + dy, c.score = s, moved = true;
      }
    if (!moved) break;
  }
  auto vertex = [](double sm, double s0, double sp) {
    const double den = sm - 2 * s0 + sp;
    return den < 0 ? std::clamp(0.5 * (sm - sp) / den, -0.5, 0.5) : 0.0;
  };
  int sign = 1;
  rotateModel(0, c.phi);
  const int cx = cvRound(c.x), cy = cvRound(c.y);
  const double s0 = scoreAt(0, cx, cy, sign);
  const double ox = vertex(scoreAt(0, cx - 1, cy, sign), s0, scoreAt(0, cx + 1, cy, sign));
  const double oy = vertex(scoreAt(0, cx, cy - 1, sign), s0, scoreAt(0, cx, cy + 1, sign));
  rotateModel(0, c.phi - step);
  const double sm = scoreAt(0, cx, cy, sign);
  rotateModel(0, c.phi + step);
  const double sp = scoreAt(0, cx, cy, sign);
  const double oa = vertex(sm, s0, sp);
  c.x = cx + ox, c.y = cy + oy, c.phi += oa * step;
  rotateModel(0, c.phi);
  c.score = scoreAt(0, cx, cy, c.sign);
}

// Least squares on point-to-tangent distances (Gauss-Newton over (tx, ty, phi)): each model
// point, placed by the current pose, looks along its normal for the sub-pixel image edge
// (shape::edgeAlongNormal); the residual is that signed distance, r_i = n_i . (e_i - q_i),
// and moving the pose by (dtx, dty, dphi) changes it by -n_i . (dtx - dphi q'_iy, dty + dphi q'_ix)
// with q'_i the rotated model point. Tukey weights drop occluded and cluttered points.
void ShapeLocator::refine(Candidate& c) {
  const LevelModel& lm = m_.levels[0];
  const bool absLocal = p_.polarity == ShapePolarity::IgnoreLocal;
  const double sign = c.sign;
  double tukey = 2.0;
  for (int it = 0; it < 6; ++it) {
    rotateModel(0, c.phi);
    Eigen::Matrix3d a = Eigen::Matrix3d::Zero();
    Eigen::Vector3d b = Eigen::Vector3d::Zero();
    int used = 0;
    for (int k = 0; k < lm.size(); ++k) {
      const double qx = rx_[k], qy = ry_[k], nx = rnx_[k], ny = rny_[k];
      double t = 0, mag = 0;
      if (!shape::edgeAlongNormal(sgx_, sgy_, c.x + qx, c.y + qy, nx, ny, 2.0, sign, absLocal, p_.minContrast, t, mag))
        continue;
      if (std::abs(t) >= tukey) continue;
      const double u = t / tukey;
      // Tukey's biweight times the point's share of outline length: a digital edge has
      // max(|nx|, |ny|) points per px of length, so diagonal edges would otherwise weigh up to
      // 1.4x more and any bias common to all edges would become a translation.
      const double w = (1 - u * u) * (1 - u * u) / std::max(std::abs(lm.nx[k]), std::abs(lm.ny[k]));
      const Eigen::Vector3d j(nx, ny, -nx * qy + ny * qx);
      a += w * j * j.transpose();
      b += w * j * t;
      ++used;
    }
    if (used < 8) return;
    const Eigen::Vector3d d = a.ldlt().solve(b);
    if (!d.allFinite()) return;
    c.x += d(0), c.y += d(1), c.phi += d(2);
    tukey = 1.0;
    if (std::abs(d(0)) < 1e-4 && std::abs(d(1)) < 1e-4 && std::abs(d(2)) * lm.radius < 1e-4) break;
  }
}

// Height-aware grasp (paper 000's projection difference, Sec. I): a raised region of the part
// shows shifted radially against the base by up to tens of px, so after the rigid fit the
// grasp point's region looks for its own translation, rotation shared: an exhaustive search
// of its gradient-direction score over +-regionShiftPx (2 px steps, then 1 px), then least
// squares on its point-to-tangent distances for (tx, ty) only. (tx, ty): the model origin's
// position for that region, px of level 0; unchanged when the region is not found.
void ShapeLocator::settleGraspRegion(const Candidate& c, double& tx, double& ty) {
  tx = c.x, ty = c.y;
  if (graspRegionPts_.empty()) return;
  rotateModel(0, c.phi);
  const cv::Mat& u = nx_[0];
  const cv::Mat& v = ny_[0];
  const int n = static_cast<int>(graspRegionPts_.size());
  auto score = [&](int dx, int dy) {
    double sum = 0;
    for (const int k : graspRegionPts_) {
      const int xx = cvRound(c.x) + dx + ix_[k], yy = cvRound(c.y) + dy + iy_[k];
      if (xx < 0 || yy < 0 || xx >= u.cols || yy >= u.rows) continue;
      const float d = rnx_[k] * u.ptr<float>(yy)[xx] + rny_[k] * v.ptr<float>(yy)[xx];
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
      if (!shape::edgeAlongNormal(sgx_, sgy_, x + rx_[k], y + ry_[k], rnx_[k], rny_[k], 2.0, c.sign,
                                  p_.polarity == ShapePolarity::IgnoreLocal, p_.minContrast, t, mag) ||
          std::abs(t) >= tukey)
        continue;
      const double q = t / tukey;
      const double w = (1 - q * q) * (1 - q * q);
      const Eigen::Vector2d j(rnx_[k], rny_[k]);
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

// Greedy non-maximum suppression: a candidate within distPx and angle of a better one goes.
void ShapeLocator::suppress(std::vector<Candidate>& cands, double distPx, double angle, std::size_t keep) const {
  std::sort(cands.begin(), cands.end(), [](const Candidate& l, const Candidate& r) { return l.score > r.score; });
  std::size_t out = 0;
  for (std::size_t i = 0; i < cands.size() && out < keep; ++i) {
    bool dup = false;
    for (std::size_t j = 0; j < out && !dup; ++j)
      dup = std::hypot(cands[i].x - cands[j].x, cands[i].y - cands[j].y) <= distPx &&
            (angle <= 0 || angleDist(cands[i].phi, cands[j].phi) <= angle);
    if (!dup) cands[out++] = cands[i];
  }
  cands.resize(out);
}

Result<LocateOutput> ShapeLocator::locate(const cv::Mat& gray) {
  if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "shape: expected a non-empty 8-bit gray image");
  cv::Rect roi(0, 0, gray.cols, gray.rows);
  if (!taught_.searchRoi.empty())
    roi &= cv::Rect(taught_.searchRoi.x, taught_.searchRoi.y, taught_.searchRoi.width, taught_.searchRoi.height);
  LocateOutput out;
  const int top = static_cast<int>(m_.levels.size()) - 1;
  const int minSide = 1 << top;
  if (roi.width < 2 * minSide || roi.height < 2 * minSide) return out;
  prepare(roi.size());

  pyr_[0] = gray(roi);
  for (int l = 1; l <= top; ++l) cv::pyrDown(pyr_[l - 1], pyr_[l], pyr_[l].size(), cv::BORDER_REPLICATE);

  // Top level: full gradient, unit directions into the zero-padded planes.
  {
    cv::Sobel(pyr_[top], gx_[top], CV_32F, 1, 0, 3, 1.0 / 8, 0, cv::BORDER_REPLICATE);
    cv::Sobel(pyr_[top], gy_[top], CV_32F, 0, 1, 3, 1.0 / 8, 0, cv::BORDER_REPLICATE);
    const float minC = static_cast<float>(p_.minContrast);
    for (int y = 0; y < topH_; ++y) {
      const float* a = gx_[top].ptr<float>(y);
      const float* b = gy_[top].ptr<float>(y);
      float* u = nx_[top].ptr<float>(y);
      float* v = ny_[top].ptr<float>(y);
      float* pu = topX_.data() + static_cast<std::size_t>(y + pad_) * stride_ + pad_;
      float* pv = topY_.data() + static_cast<std::size_t>(y + pad_) * stride_ + pad_;
      for (int x = 0; x < topW_; ++x) {
        const float m = std::sqrt(a[x] * a[x] + b[x] * b[x]);
        const float inv = m >= minC && m > 0 ? 1.0f / m : 0.0f;
        u[x] = pu[x] = a[x] * inv;
        v[x] = pv[x] = b[x] * inv;
      }
    }
  }
  const double minScore = taught_.minScore;
  const double coarseThr = minScore * kCoarseSlack;
  const int nw = static_cast<int>(workers_.size());
  for (Worker& w : workers_) w.found.clear();
  cv::parallel_for_(cv::Range(0, nw), [&](const cv::Range& r) {
    for (int i = r.start; i < r.end; ++i) searchTop(workers_[i], i, nw, coarseThr);
  }, nw);
  cands_.clear();
  for (const Worker& w : workers_) cands_.insert(cands_.end(), w.found.begin(), w.found.end());
  const std::size_t keep = static_cast<std::size_t>(4 * taught_.maxParts + 4);
  suppress(cands_, 1.5, 1.5 * topStep_, keep);

  for (int l = top - 1; l >= 0; --l) {
    next_.clear();
    for (Candidate c : cands_)
      if (trackDown(l, c, l == 0 ? minScore : coarseThr)) next_.push_back(c);
    suppress(next_, 2.0, 2.5 * m_.levels[l].angleStep, keep);
    cands_.swap(next_);
  }

  // Full resolution, best first: overlap control, then the sub-pixel pose, until maxParts.
  // Only parts that make the output pay for the refinement.
  std::sort(cands_.begin(), cands_.end(), [](const Candidate& l, const Candidate& r) { return l.score > r.score; });
  next_.clear();
  const double tol = m_.levels[0].angleStep * 180 / std::numbers::pi;
  auto overlapsKept = [&](const Candidate& c) {
    for (const Candidate& k : next_) {
      const double q = std::hypot(c.x - k.x, c.y - k.y) / (2 * eqRadius_);
      const double f = q < 1 ? 2 / std::numbers::pi * (std::acos(q) - q * std::sqrt(1 - q * q)) : 0.0;
      if (f > p_.maxOverlap) return true;
    }
    return false;
  };
  for (Candidate c : cands_) {
    if (static_cast<int>(next_.size()) >= taught_.maxParts) break;
    if (overlapsKept(c)) continue;
    interpolatePeak(c);
    if (p_.refine) {
      smoothGradients(c);
      refine(c);
    }
    double tx = c.x, ty = c.y;
    if (p_.refine) settleGraspRegion(c, tx, ty);
    if (c.score < minScore || overlapsKept(c)) continue;
    const double angleDeg = normaliseDeg(-c.phi * 180 / std::numbers::pi);
    if (!fullCircle_ && (angleDeg < taught_.angleMinDeg - tol || angleDeg > taught_.angleMaxDeg + tol)) continue;
    next_.push_back(c);
    const double cs = std::cos(c.phi), sn = std::sin(c.phi);
    const double gx = taught_.grasp.u - m_.origin.u, gy = taught_.grasp.v - m_.origin.v;
    Detection d;
    d.u = roi.x + tx + cs * gx - sn * gy;
    d.v = roi.y + ty + sn * gx + cs * gy;
    d.angleDeg = angleDeg;
    d.score = c.score;
    out.parts.push_back(d);
  }
  return out;
}

}  // namespace

Result<ShapeParams> parseShapeParams(const TaughtTemplate& taught) {
  // "polarity" is a word, which ParamReader does not read: take it out, check it here.
  std::map<std::string, std::string> numeric = taught.params;
  numeric.erase("polarity");
  ParamReader r("shape", numeric);
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
                  fmt::format("shape: parameter 'polarity': expected use, ignore_global or ignore_local, got '{}'", it->second));
    }
  }
  if (taught.minScore < 0 || taught.minScore > 1)
    return fail(Status::BadArgument, fmt::format("shape: min_score must be in [0, 1], got {}", taught.minScore));
  if (!(taught.angleMinDeg <= taught.angleMaxDeg) || taught.angleMinDeg < -360 || taught.angleMaxDeg > 360)
    return fail(Status::BadArgument, fmt::format("shape: angle range [{}, {}] deg is not a range within [-360, 360]",
                                                 taught.angleMinDeg, taught.angleMaxDeg));
  return p;
}

Result<std::unique_ptr<Locator>> makeShapeLocator(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  auto params = parseShapeParams(taught);
  if (!params) return std::unexpected(params.error());
  auto model = shape::buildModel(templateGray, *params);
  if (!model) return std::unexpected(model.error());
  return std::make_unique<ShapeLocator>(*params, std::move(*model), taught);
}

}  // namespace vgr::vision
