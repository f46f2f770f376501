#include "vision/locate/shape_model.hpp"

#include <algorithm>
#include <cmath>
#include <numeric>

#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace vgr::vision::shape {
namespace {

constexpr int kMaxLevels = 7;
constexpr int kMinTopPoints = 24;
constexpr double kMinTopRadius = 8.0;
constexpr std::size_t kMinLevelPoints = 64;

inline float sampleBilinear(const cv::Mat& m, double x, double y) {
  const int x0 = static_cast<int>(std::floor(x)), y0 = static_cast<int>(std::floor(y));
  const float fx = static_cast<float>(x - x0), fy = static_cast<float>(y - y0);
  const float* r0 = m.ptr<float>(y0);
  const float* r1 = m.ptr<float>(y0 + 1);
  return (1 - fy) * ((1 - fx) * r0[x0] + fx * r0[x0 + 1]) + fy * ((1 - fx) * r1[x0] + fx * r1[x0 + 1]);
}

struct RawPoint {
  float x, y, nx, ny;
};

// Edge points of one level: non-maximum suppression of the gradient magnitude across the edge
// (Canny's first step, without hysteresis: the model wants clean outline points only), then
// the sub-pixel position along the gradient direction.
std::vector<RawPoint> extractEdges(const cv::Mat& img8, double contrast, bool smooth) {
  cv::Mat gx, gy, scratch;
  gradient(img8, gx, gy, smooth, scratch);
  cv::Mat mag;
  cv::magnitude(gx, gy, mag);
  std::vector<RawPoint> pts;
  const int border = 2;
  for (int y = border; y < img8.rows - border; ++y) {
    const float* m = mag.ptr<float>(y);
    const float* mu = mag.ptr<float>(y - 1);
    const float* md = mag.ptr<float>(y + 1);
    const float* gxr = gx.ptr<float>(y);
    const float* gyr = gy.ptr<float>(y);
    for (int x = border; x < img8.cols - border; ++x) {
      const float v = m[x];
      if (v < contrast) continue;
      const float ax = std::abs(gxr[x]), ay = std::abs(gyr[x]);
      float a, b;  // the two neighbours across the edge
      if (ax > 2.4142f * ay) {
        a = m[x - 1], b = m[x + 1];
      } else if (ay > 2.4142f * ax) {
        a = mu[x], b = md[x];
      } else if (gxr[x] * gyr[x] > 0) {
        a = mu[x - 1], b = md[x + 1];
      } else {
        a = mu[x + 1], b = md[x - 1];
      }
      if (!(v >= a && v > b)) continue;
      const double nx = gxr[x] / v, ny = gyr[x] / v;
      double t = 0, peak = 0;
      if (!edgeAlongNormal(gx, gy, x, y, nx, ny, 1.0, 1.0, false, contrast, t, peak)) t = 0;
      pts.push_back({static_cast<float>(x + t * nx), static_cast<float>(y + t * ny), static_cast<float>(nx),
                     static_cast<float>(ny)});
    }
  }
  return pts;
}

}  // namespace

void gradient(const cv::Mat& src8, cv::Mat& gx, cv::Mat& gy, bool smooth, cv::Mat& scratch) {
  const cv::Mat* src = &src8;
  if (smooth) {
    src8.convertTo(scratch, CV_32F);
    cv::GaussianBlur(scratch, scratch, cv::Size(7, 7), 1.0, 1.0, cv::BORDER_REPLICATE);
    src = &scratch;
  }
  cv::Sobel(*src, gx, CV_32F, 1, 0, 3, 1.0 / 8, 0, cv::BORDER_REPLICATE);
  cv::Sobel(*src, gy, CV_32F, 0, 1, 3, 1.0 / 8, 0, cv::BORDER_REPLICATE);
}

bool edgeAlongNormal(const cv::Mat& gx, const cv::Mat& gy, double px, double py, double nx, double ny, double range,
                     double s, bool absPolarity, double minMag, double& t, double& mag) {
  constexpr double kStep = 1.0;
  constexpr int kMaxSamples = 9;
  const int half = std::min(static_cast<int>(range / kStep), (kMaxSamples - 1) / 2);
  const int n = 2 * half + 1;
  // Both ends inside the map (bilinear needs x0 + 1 and y0 + 1).
  for (const int k : {-half, half}) {
    const double x = px + k * kStep * nx, y = py + k * kStep * ny;
    if (x < 0 || y < 0 || x >= gx.cols - 1 || y >= gx.rows - 1) return false;
  }
  double f[kMaxSamples];
  for (int i = 0; i < n; ++i) {
    const double tt = (i - half) * kStep;
    const double x = px + tt * nx, y = py + tt * ny;
    const double d = nx * sampleBilinear(gx, x, y) + ny * sampleBilinear(gy, x, y);
    f[i] = absPolarity ? std::abs(d) : s * d;
  }
  // The interior maximum; an end sample that ties with it is not better: an edge exactly
  // between two samples gives two equal ones, and its peak is between them (taking the end
  // sample there lost every edge on a pixel border whose normal points to +x or +y).
  int best = 1;
  for (int i = 2; i < n - 1; ++i)
    if (f[i] > f[best]) best = i;
  if (n < 3 || f[0] > f[best] || f[n - 1] > f[best] || f[best] < minMag) return false;
  // Gaussian through the three samples (a parabola through their logarithms): the smoothed
  // gradient across a blurred step edge is close to a Gaussian, for which this is exact,
  // where a plain parabola is biased toward the sample by up to ~0.05 px.
  double delta = 0;
  if (f[best - 1] > 0 && f[best + 1] > 0) {
    const double lm = std::log(f[best - 1]), l0 = std::log(f[best]), lp = std::log(f[best + 1]);
    const double den = lm - 2 * l0 + lp;
    if (den < 0) delta = std::clamp(0.5 * (lm - lp) / den, -0.5, 0.5);
  }
  t = (best - half + delta) * kStep;
  mag = f[best];
  return true;
}

int Model::templateLevel(int level, double scale) const {
  const int l = static_cast<int>(std::lround(level + std::log2(1.0 / scale)));
  return std::clamp(l, 0, static_cast<int>(levels.size()) - 1);
}

Result<Model> buildModel(const cv::Mat& templ, const ShapeParams& params, double scaleMin) {
  // Replicated border: edges near the template's border stay away from the pyramid's border.
  const int border = 1 << kMaxLevels;
  cv::Mat padded;
  cv::copyMakeBorder(templ, padded, border, border, border, border, cv::BORDER_REPLICATE);
  std::vector<cv::Mat> pyr{padded};
  while (static_cast<int>(pyr.size()) < kMaxLevels + 2 && pyr.back().cols >= 24 && pyr.back().rows >= 24) {
    cv::Mat next;
    cv::pyrDown(pyr.back(), next, cv::Size(), cv::BORDER_REPLICATE);
    pyr.push_back(next);
  }
  std::vector<std::vector<RawPoint>> raw;
  for (std::size_t l = 0; l < pyr.size(); ++l) {
    raw.push_back(extractEdges(pyr[l], params.modelContrast, l == 0));
    if (l > 0 && raw.back().size() < 8) {
      raw.pop_back();
      break;
    }
  }
  if (raw[0].size() < 16)
    return fail(Status::BadArgument, fmt::format("shape: the template has only {} edge points of contrast >= {} "
                                                 "(parameter 'model_contrast'); need at least 16",
                                                 raw[0].size(), params.modelContrast));
  Model model;
  double cx = 0, cy = 0;
  for (const auto& p : raw[0]) cx += p.x, cy += p.y;
  model.origin = {cx / raw[0].size(), cy / raw[0].size()};  // padded template px

  for (std::size_t l = 0; l < raw.size(); ++l) {
    const double s = std::ldexp(1.0, -static_cast<int>(l));
    std::vector<RawPoint> pts = raw[l];
    // Thin out evenly to maxPoints / 2^l (at least kMinLevelPoints): a level's outline is half
    // as long as the one below it, so this keeps about one point per 2^l px of it where
    // the template has many edges (a 450 px gear: 1500, 750, 375, 187, 93 points on levels
    // 0-4), which is plenty to score a pose and costs 2^l less to track.
    const std::size_t cap =
        std::max<std::size_t>(kMinLevelPoints, static_cast<std::size_t>(params.maxPoints) >> std::min<std::size_t>(l, 16));
    if (pts.size() > cap) {
      std::vector<RawPoint> kept;
      kept.reserve(cap);
      for (std::size_t i = 0; i < cap; ++i) kept.push_back(pts[i * pts.size() / cap]);
      pts.swap(kept);
    }
    // Order the points with a stride coprime to their count, so every prefix (what the early
    // termination has looked at) is spread over the whole outline.
    const std::size_t n = pts.size();
    std::size_t stride = std::max<std::size_t>(1, static_cast<std::size_t>(n * 0.618));
    while (std::gcd(stride, n) != 1) ++stride;
    LevelModel lm;
    for (std::size_t i = 0; i < n; ++i) {
      const RawPoint& p = pts[(i * stride) % n];
      lm.x.push_back(static_cast<float>(p.x - model.origin.u * s));
      lm.y.push_back(static_cast<float>(p.y - model.origin.v * s));
      lm.nx.push_back(p.nx);
      lm.ny.push_back(p.ny);
      lm.radius = std::max(lm.radius, std::hypot(double{lm.x.back()}, double{lm.y.back()}));
    }
    lm.angleStep = params.angleStepDeg > 0 ? std::min(params.angleStepDeg * M_PI / 180.0 * std::ldexp(1.0, static_cast<int>(l)), 0.5)
                                           : std::min(1.0 / std::max(lm.radius, 1.0), 0.5);
    model.levels.push_back(std::move(lm));
  }

  // Search levels: as asked, or the highest at which the part at scaleMin is still big enough.
  const int available = static_cast<int>(model.levels.size());
  int levels = params.levels;
  if (levels == 0) {
    levels = 1;
    for (int l = 1; l < std::min(available, kMaxLevels); ++l) {
      const int tl = model.templateLevel(l, scaleMin);
      const double radius = model.levels[0].radius * scaleMin * std::ldexp(1.0, -l);
      if (model.levels[tl].size() >= kMinTopPoints && radius >= kMinTopRadius) levels = l + 1;
    }
  } else if (levels > available || model.levels[model.templateLevel(levels - 1, scaleMin)].size() < 8) {
    return fail(Status::BadArgument, fmt::format("shape: parameter 'levels': the template is too small for {} levels{}", levels,
                                                 scaleMin < 1 ? fmt::format(" at scale {}", scaleMin) : std::string()));
  }
  model.searchLevels = levels;
  model.origin.u -= border, model.origin.v -= border;  // template px
  return model;
}

}  // namespace vgr::vision::shape
