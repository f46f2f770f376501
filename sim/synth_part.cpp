#include "sim/synth_part.hpp"

#include <cmath>
#include <numbers>
#include <utility>

#include <opencv2/imgproc.hpp>

namespace vgr::sim::synth {

SynthPart makeTexturedPart(bool multiHeight) {
  SynthPart part;
  part.canvas = {320, 220};
  part.grasp = {95, 120};
  std::mt19937 rng(1234);
  std::uniform_int_distribution<int> gray(70, 235), small(4, 14);

  PartLayer base;
  base.outline = {{10, 30}, {60, 8}, {300, 8}, {312, 40}, {312, 210}, {40, 212}, {10, 180}};
  base.texture = cv::Mat(part.canvas, CV_8U, cv::Scalar(kBackground));
  base.alpha = cv::Mat(part.canvas, CV_8U, cv::Scalar(0));
  cv::fillPoly(base.alpha, std::vector<std::vector<cv::Point>>{base.outline}, cv::Scalar(255), cv::LINE_AA);
  cv::fillPoly(base.texture, std::vector<std::vector<cv::Point>>{base.outline}, cv::Scalar(130), cv::LINE_AA);
  for (int k = 0; k < 90; ++k) {
    const cv::Point c(std::uniform_int_distribution<int>(25, 295)(rng),
                      std::uniform_int_distribution<int>(25, 195)(rng));
    if (k % 3 == 0)
      cv::circle(base.texture, c, small(rng), cv::Scalar(gray(rng)), cv::FILLED, cv::LINE_AA);
    else if (k % 3 == 1)
      cv::rectangle(base.texture, cv::Rect(c, cv::Size(small(rng), small(rng))), cv::Scalar(gray(rng)), cv::FILLED,
                    cv::LINE_AA);
    else
      cv::line(base.texture, c, c + cv::Point(small(rng) * 2, small(rng) - 9), cv::Scalar(gray(rng)), 2, cv::LINE_AA);
  }
  cv::putText(base.texture, "VGR-42", {40, 200}, cv::FONT_HERSHEY_SIMPLEX, 0.8, cv::Scalar(225), 2, cv::LINE_AA);
  // Two through holes: the belt shows through.
  for (const auto& [c, r] : {std::pair{cv::Point(60, 60), 14}, std::pair{cv::Point(160, 150), 18}}) {
    cv::circle(base.alpha, c, r, cv::Scalar(0), cv::FILLED, cv::LINE_AA);
    cv::circle(base.texture, c, r, cv::Scalar(kBackground), cv::FILLED, cv::LINE_AA);
  }
  part.layers.push_back(std::move(base));

  if (multiHeight) {
    auto raised = [&](std::vector<cv::Point> outline, double height, int level) {
      PartLayer l;
      l.outline = std::move(outline);
      l.heightMm = height;
      l.texture = cv::Mat(part.canvas, CV_8U, cv::Scalar(0));
      l.alpha = cv::Mat(part.canvas, CV_8U, cv::Scalar(0));
      cv::fillPoly(l.alpha, std::vector<std::vector<cv::Point>>{l.outline}, cv::Scalar(255), cv::LINE_AA);
      cv::fillPoly(l.texture, std::vector<std::vector<cv::Point>>{l.outline}, cv::Scalar(level), cv::LINE_AA);
      const cv::Rect box = cv::boundingRect(l.outline);
      for (int k = 0; k < 25; ++k) {
        const cv::Point c(box.x + 6 + std::uniform_int_distribution<int>(0, std::max(1, box.width - 12))(rng),
                          box.y + 6 + std::uniform_int_distribution<int>(0, std::max(1, box.height - 12))(rng));
        cv::circle(l.texture, c, small(rng) / 2 + 2, cv::Scalar(gray(rng)), cv::FILLED, cv::LINE_AA);
      }
      part.layers.push_back(std::move(l));
    };
    raised({{200, 70}, {290, 70}, {290, 180}, {200, 180}}, 30.0, 185);
    raised({{120, 18}, {290, 18}, {290, 40}, {120, 40}}, 45.0, 205);
  }
  return part;
}

cv::Mat layerWarp(const SynthPart& part, const PartPose& pose, double heightMm, cv::Point2d pp) {
  const double a = pose.angleDeg * std::numbers::pi / 180.0, c = std::cos(a), s = std::sin(a);
  // (x, y) -> (x c + y s, -x s + y c): counter-clockwise as displayed (y down).
  const double tx = pose.u - (c * part.grasp.x + s * part.grasp.y);
  const double ty = pose.v - (-s * part.grasp.x + c * part.grasp.y);
  const double k = kCameraHeightMm / (kCameraHeightMm - heightMm);
  cv::Mat M = (cv::Mat_<double>(2, 3) << k * c, k * s, pp.x + k * (tx - pp.x), -k * s, k * c, pp.y + k * (ty - pp.y));
  return M;
}

cv::Mat renderScene(const SynthPart& part, const std::vector<PartPose>& poses, cv::Size size, double noiseSigma,
                    std::uint64_t seed) {
  cv::Mat scene(size, CV_32F, cv::Scalar(kBackground));
  const cv::Point2d pp(0.5 * (size.width - 1), 0.5 * (size.height - 1));
  for (const PartPose& pose : poses)
    for (const PartLayer& l : part.layers) {
      const cv::Mat M = layerWarp(part, pose, l.heightMm, pp);
      cv::Mat tex, alpha;
      cv::warpAffine(l.texture, tex, M, size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
      cv::warpAffine(l.alpha, alpha, M, size, cv::INTER_LINEAR, cv::BORDER_CONSTANT, cv::Scalar(0));
      cv::Mat texF, alphaF;
      tex.convertTo(texF, CV_32F);
      alpha.convertTo(alphaF, CV_32F, 1.0 / 255.0);
      // The texture is premultiplied by the anti-aliased coverage already (drawn on 0 / belt).
      scene = scene.mul(1.0 - alphaF) + texF.mul(alphaF);
    }
  if (noiseSigma > 0) {
    cv::Mat noise(size, CV_32F);
    cv::RNG rng(seed);
    rng.fill(noise, cv::RNG::NORMAL, 0.0, noiseSigma);
    scene += noise;
  }
  cv::Mat out;
  scene.convertTo(out, CV_8U);
  return out;
}

SynthTemplate makeTemplate(const SynthPart& part, int margin, double raisedHeightFactor) {
  SynthTemplate t;
  const cv::Size size(part.canvas.width + 2 * margin, part.canvas.height + 2 * margin);
  t.grasp = {part.grasp.x + margin, part.grasp.y + margin};
  const PartPose pose{t.grasp.u, t.grasp.v, 0.0};
  t.image = renderScene(part, {pose}, size, 0.0, 0);
  const cv::Point2d pp(0.5 * (size.width - 1), 0.5 * (size.height - 1));
  for (size_t k = part.layers.size(); k-- > 0;) {
    const PartLayer& l = part.layers[k];
    const cv::Mat M = layerWarp(part, pose, l.heightMm, pp);
    std::vector<cv::Point2f> src, dst;
    for (const cv::Point& p : l.outline) src.emplace_back(static_cast<float>(p.x), static_cast<float>(p.y));
    cv::transform(src, dst, M);
    // Grow the polygon 4 px about its centroid so that its own edge pixels fall inside.
    cv::Point2f c(0, 0);
    for (const auto& p : dst) c += p;
    c *= 1.0f / static_cast<float>(dst.size());
    vision::TemplateRegion r;
    for (const auto& p : dst) {
      const cv::Point2f d = p - c;
      const float n = std::hypot(d.x, d.y);
      const cv::Point2f q = p + d * (4.0f / std::max(n, 1.0f));
      r.polygon.push_back({q.x, q.y});
    }
    r.heightMm = l.heightMm;
    r.heightFactor = l.heightMm > 0 ? raisedHeightFactor : 1.0;
    t.regions.push_back(std::move(r));
  }
  return t;
}

PartPose randomPose(std::mt19937& rng, cv::Size size, double maxAngleDeg) {
  std::uniform_real_distribution<double> u(260, size.width - 260.0), v(230, size.height - 230.0),
      a(-maxAngleDeg, maxAngleDeg);
  return {u(rng), v(rng), a(rng)};
}

std::vector<PartPose> threePoses(std::mt19937& rng, cv::Size size, double maxAngleDeg) {
  std::vector<PartPose> out;
  std::uniform_real_distribution<double> jitter(-15, 15), v(300, size.height - 300.0), a(-maxAngleDeg, maxAngleDeg);
  for (int k = 0; k < 3; ++k) out.push_back({size.width * (k + 0.5) / 3.0 - 20 + jitter(rng), v(rng), a(rng)});
  return out;
}

double angleDiffDeg(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

double matchTruePositiveRate(const std::vector<vision::MatchPair>& matches, const PartPose& truth,
                             vision::PixelPoint templateGrasp, double tolPx) {
  if (matches.empty()) return 0;
  const double a = truth.angleDeg * std::numbers::pi / 180.0, c = std::cos(a), s = std::sin(a);
  int good = 0;
  for (const auto& m : matches) {
    const double x = m.templatePx.u - templateGrasp.u, y = m.templatePx.v - templateGrasp.v;
    const double u = truth.u + x * c + y * s, v = truth.v - x * s + y * c;
    if (std::hypot(u - m.imagePx.u, v - m.imagePx.v) <= tolPx) ++good;
  }
  return static_cast<double>(good) / static_cast<double>(matches.size());
}

cv::Mat renderDistractorScene(cv::Size size, double noiseSigma, std::uint64_t seed) {
  cv::Mat img(size, CV_8U, cv::Scalar(kBackground));
  std::mt19937 rng(static_cast<unsigned>(seed) + 77);
  std::uniform_int_distribution<int> gray(70, 235), x(400, 800), y(300, 700), r(3, 12);
  cv::rectangle(img, cv::Rect(380, 280, 440, 440), cv::Scalar(120), cv::FILLED);
  for (int k = 0; k < 120; ++k)
    cv::circle(img, {x(rng), y(rng)}, r(rng), cv::Scalar(gray(rng)), cv::FILLED, cv::LINE_AA);
  cv::Mat noise(size, CV_32F), f;
  cv::RNG(seed).fill(noise, cv::RNG::NORMAL, 0.0, noiseSigma);
  img.convertTo(f, CV_32F);
  f += noise;
  f.convertTo(img, CV_8U);
  return img;
}

size_t nearestPose(const std::vector<PartPose>& poses, double u, double v) {
  size_t best = 0;
  for (size_t k = 1; k < poses.size(); ++k)
    if (std::hypot(poses[k].u - u, poses[k].v - v) < std::hypot(poses[best].u - u, poses[best].v - v)) best = k;
  return best;
}

}  // namespace vgr::sim::synth
