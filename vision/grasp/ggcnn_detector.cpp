#include "vision/grasp/ggcnn_detector.hpp"

#include <algorithm>
#include <cmath>
#include <filesystem>

#include <fmt/core.h>
#include <opencv2/core/utils/logger.hpp>
#include <opencv2/dnn.hpp>
#include <opencv2/imgproc.hpp>

#include "vision/grasp/grasp_input.hpp"

namespace vgr::vision::grasp {
namespace {

constexpr double kDeg = M_PI / 180.0;
constexpr double kPeakSigmaPx = 1.0;   // network px
constexpr int kPeakSeparationPx = 5;   // network px
constexpr int kRerankFactor = 4;          // peaks looked at per grasp returned, when the jaw check re-ranks them
constexpr double kJawBlockedShare = 0.1;  // more of a footprint's pixels with data in the way: the jaw collides

// The jaws (docs/grasp.md "Network"): a jaw comes down beside the grasp along the optical
// axis to the height of the grasp centre. Its footprint on the height map (mm, NaN = no
// data) is a band jawThicknessMm across, jawLengthMm along, its inner face `inner` px from the
// centre on `side` of the closing axis; it is clear when the band lies at least marginMm below
// the centre's height: the truth's rule 3 (docs/grasp.md "Ground truth") on the measured image
// instead of the exact surfaces. Up to kJawBlockedShare of its pixels with data may be in the
// way (single noisy pixels at depth jumps); pixels without data do not count.
struct JawGeometry {
  cv::Point2d centre, across, along;
  double thickPx = 0, lenPx = 0, limitMm = 0;
};

JawGeometry jawGeometry(const Grasp& g, double pxPerMm, double thicknessMm, double marginMm) {
  const double th = g.angleDeg * kDeg;
  return {{g.u, g.v}, {std::cos(th), -std::sin(th)}, {std::sin(th), std::cos(th)}, thicknessMm * pxPerMm, g.jawPx, g.heightMm - marginMm};
}

bool jawClear(const cv::Mat& heights, const JawGeometry& j, int side, double inner) {
  int valid = 0, blocked = 0;
  for (double t = inner + 0.5; t <= inner + j.thickPx; t += 1.0)
    for (double l = -j.lenPx / 2; l <= j.lenPx / 2; l += 1.0) {
      const cv::Point2d p = j.centre + j.across * (side * t) + j.along * l;
      const int x = static_cast<int>(std::lround(p.x)), y = static_cast<int>(std::lround(p.y));
      if (x < 0 || y < 0 || x >= heights.cols || y >= heights.rows) continue;
      const float h = heights.at<float>(y, x);
      if (!std::isfinite(h)) continue;
      ++valid;
      blocked += h > j.limitMm;
    }
  return blocked <= kJawBlockedShare * valid;
}

// The nearest clear place of a jaw on `side`, px from the centre (the object's face there),
// searched outward 1 px at a time up to maxPx; -1 when there is none.
double nearestClear(const cv::Mat& heights, const JawGeometry& j, int side, double maxPx) {
  for (double t = 0; t <= maxPx; t += 1.0)
    if (jawClear(heights, j, side, t)) return t;
  return -1;
}

// OpenCV's exception text is several lines ("OpenCV(4.6.0) file:line: error: (-5:Bad
// argument) WHY in function 'f'", nested for ONNX nodes): the innermost WHY, on one line.
std::string reasonOf(const std::string& what) {
  std::string s = what;
  const std::size_t at = s.rfind("error: (");
  if (at != std::string::npos) {
    const std::size_t close = s.find(") ", at);
    if (close != std::string::npos) s = s.substr(close + 2);
    const std::size_t fn = s.find(" in function");
    if (fn != std::string::npos) s = s.substr(0, fn);
  }
  for (char& c : s)
    if (c == '\n' || c == '\r') c = ' ';
  while (!s.empty() && s.back() == ' ') s.pop_back();
  return s.empty() ? "unknown error" : s;
}

// OpenCV logs its own ERROR lines while it fails to import: quiet while we load, our one
// line says what happened.
class QuietOpenCvLog {
 public:
  QuietOpenCvLog() : saved_(cv::utils::logging::setLogLevel(cv::utils::logging::LOG_LEVEL_SILENT)) {}
  ~QuietOpenCvLog() { cv::utils::logging::setLogLevel(saved_); }
  QuietOpenCvLog(const QuietOpenCvLog&) = delete;
  QuietOpenCvLog& operator=(const QuietOpenCvLog&) = delete;

 private:
  cv::utils::logging::LogLevel saved_;
};

// The 4 output planes of a 1 x 4 x H x W blob (views into it).
bool outputPlanes(const cv::Mat& out, int rows, int cols, cv::Mat planes[4]) {
  if (out.dims != 4 || out.size[0] != 1 || out.size[1] != 4 || out.size[2] != rows || out.size[3] != cols || out.type() != CV_32F)
    return false;
  for (int c = 0; c < 4; ++c) planes[c] = cv::Mat(rows, cols, CV_32FC1, const_cast<float*>(out.ptr<float>(0, c)));
  return true;
}

std::string shapeOf(const cv::Mat& m) {
  std::string s;
  for (int i = 0; i < m.dims; ++i) s += (i ? " x " : "") + std::to_string(m.size[i]);
  return s.empty() ? "nothing" : s;
}

class GgcnnDetector final : public GraspDetector {
 public:
  GgcnnDetector(cv::dnn::Net net, GraspDetectorOptions o) : net_(std::move(net)), o_(std::move(o)) {}
  std::string_view name() const override { return "ggcnn"; }

  Result<std::vector<Grasp>> detect(const DepthFrame& f) override {
    if (auto c = checkFrame(f); !c) return std::unexpected(c.error());
    auto floor = fitFloorPlane(f.zMm, f.camera, f.name, o_.floor);
    if (!floor) return std::unexpected(floor.error());
    const cv::Mat heights = heightAboveFloor(f.zMm, f.camera, *floor);
    const auto scale = netScale(f.camera, *floor, f.name);
    if (!scale) return std::unexpected(scale.error());
    const NetInput in = makeNetInput(heights, *scale);

    cv::Mat out;
    try {
      net_.setInput(cv::dnn::blobFromImage(in.tensor));
      out = net_.forward();
    } catch (const std::exception& e) {
      return fail(Status::Internal, fmt::format("{}: the grasp network failed on {}: {}", o_.modelPath, f.name, reasonOf(e.what())));
    }
    cv::Mat planes[4];
    if (!outputPlanes(out, in.tensor.rows, in.tensor.cols, planes))
      return fail(Status::Internal, fmt::format("{}: the grasp network gave {} for a {}x{} input, expected 1 x 4 x {} x {}", o_.modelPath,
                                                shapeOf(out), in.tensor.cols, in.tensor.rows, in.tensor.rows, in.tensor.cols));
    const cv::Rect roi(0, 0, in.cols, in.rows);
    cv::Mat q, cs, sn, w;
    cv::GaussianBlur(planes[0](roi), q, cv::Size(0, 0), kPeakSigmaPx);
    cv::GaussianBlur(planes[1](roi), cs, cv::Size(0, 0), kPeakSigmaPx);
    cv::GaussianBlur(planes[2](roi), sn, cv::Size(0, 0), kPeakSigmaPx);
    cv::GaussianBlur(planes[3](roi), w, cv::Size(0, 0), kPeakSigmaPx);

    // Local maxima at or above minQuality, best first.
    cv::Mat dil;
    cv::dilate(q, dil, cv::Mat());
    struct Peak {
      float q;
      int x, y;
    };
    std::vector<Peak> peaks;
    for (int y = 0; y < q.rows; ++y)
      for (int x = 0; x < q.cols; ++x) {
        const float v = q.at<float>(y, x);
        if (v >= o_.minQuality && v >= dil.at<float>(y, x)) peaks.push_back({v, x, y});
      }
    std::sort(peaks.begin(), peaks.end(), [](const Peak& a, const Peak& b) { return a.q > b.q; });

    std::vector<Grasp> grasps;
    std::vector<Peak> kept;
    for (const auto& p : peaks) {
      // The jaw check re-ranks (below): it looks at kRerankFactor times as many peaks.
      if (static_cast<int>(grasps.size()) >= (o_.checkJaws ? kRerankFactor : 1) * o_.maxGrasps) break;
      const bool near = std::any_of(kept.begin(), kept.end(), [&](const Peak& k) {
        return std::hypot(k.x - p.x, k.y - p.y) < kPeakSeparationPx;
      });
      if (near) continue;
      kept.push_back(p);
      // Sub-pixel: a parabola through the peak and its two neighbours, per axis.
      auto offset = [](float l, float c, float r) {
        const float den = l - 2 * c + r;
        return den < 0 ? std::clamp(0.5f * (l - r) / den, -0.5f, 0.5f) : 0.f;
      };
      const float dx = p.x > 0 && p.x + 1 < q.cols ? offset(q.at<float>(p.y, p.x - 1), p.q, q.at<float>(p.y, p.x + 1)) : 0.f;
      const float dy = p.y > 0 && p.y + 1 < q.rows ? offset(q.at<float>(p.y - 1, p.x), p.q, q.at<float>(p.y + 1, p.x)) : 0.f;
      Grasp g;
      g.u = netToImage(p.x + dx, in.scaleX);
      g.v = netToImage(p.y + dy, in.scaleY);
      g.quality = std::clamp(static_cast<double>(p.q), 0.0, 1.0);
      double ang = 0.5 * std::atan2(sn.at<float>(p.y, p.x), cs.at<float>(p.y, p.x)) / kDeg;
      if (ang <= -90) ang += 180;
      g.angleDeg = ang;
      g.widthPx = std::max(0.0, static_cast<double>(w.at<float>(p.y, p.x))) * kNetWidthScalePx * 2 / (in.scaleX + in.scaleY);
      g.depthMm = depthNear(f.zMm, g.u, g.v);
      if (!(g.depthMm > 0)) continue;  // no depth at the centre: unsure
      g.widthMm = g.widthPx * g.depthMm / f.camera.fx;
      if (g.widthMm > o_.gripper.maxOpeningMm) continue;
      g.jawPx = o_.gripper.jawLengthMm * f.camera.fx / g.depthMm;
      const auto pc = backProject(f.camera, g.u, g.v, g.depthMm);
      g.heightMm = floor->nx * pc.x + floor->ny * pc.y + floor->nz * pc.z - floor->offset;
      // Higher than any part stands: a bin wall or a fixture, as for the analytic detector.
      if (g.heightMm > o_.maxObjectHeightMm) continue;
      if (o_.checkJaws) {
        // The jaws: each one's nearest clear place across the closing axis on the height map
        // (the object's face there; nothing clear within the gripper's opening: not a grasp),
        // the opening read from them plus both clearances, the centre moved to the middle
        // between them. The network's own opening says what object it took this for: the
        // grasp's quality is weighed by how well it agrees with the one read (a clutter box
        // taken for a part, or a peak off the part's middle, disagrees).
        const double pxPerMm = f.camera.fx / g.depthMm;
        const JawGeometry j = jawGeometry(g, pxPerMm, o_.gripper.jawThicknessMm, o_.jawMarginMm);
        const double maxPx = o_.gripper.maxOpeningMm * pxPerMm;
        const double lo = nearestClear(heights, j, -1, maxPx), hi = nearestClear(heights, j, 1, maxPx);
        if (lo < 0 || hi < 0) continue;
        const double widthPx = lo + hi + 2 * o_.gripper.clearanceMm * pxPerMm;
        if (widthPx > maxPx) continue;
        if (o_.openingSigmaMm > 0) {
          const double dw = (widthPx - g.widthPx) / pxPerMm;
          g.quality *= std::exp(-0.5 * dw * dw / (o_.openingSigmaMm * o_.openingSigmaMm));
        }
        const cv::Point2d c = j.centre + j.across * ((hi - lo) / 2);
        const double depth = depthNear(f.zMm, c.x, c.y);
        if (!(depth > 0)) continue;
        g.u = c.x, g.v = c.y, g.depthMm = depth, g.widthPx = widthPx, g.widthMm = widthPx * depth / f.camera.fx;
        g.jawPx = o_.gripper.jawLengthMm * f.camera.fx / depth;
        const auto pm = backProject(f.camera, g.u, g.v, depth);
        g.heightMm = floor->nx * pm.x + floor->ny * pm.y + floor->nz * pm.z - floor->offset;
      }
      grasps.push_back(g);
    }
    // Best first by the weighed quality; up to maxGrasps.
    std::stable_sort(grasps.begin(), grasps.end(), [](const Grasp& a, const Grasp& b) { return a.quality > b.quality; });
    if (static_cast<int>(grasps.size()) > o_.maxGrasps) grasps.resize(static_cast<std::size_t>(o_.maxGrasps));
    return grasps;
  }

 private:
  cv::dnn::Net net_;
  GraspDetectorOptions o_;
};

}  // namespace

Result<std::unique_ptr<GraspDetector>> makeGgcnnDetector(const GraspDetectorOptions& o) {
  const std::string& path = o.modelPath;
  if (path.empty()) return fail(Status::BadArgument, "the ggcnn grasp detector needs a model: the ONNX file (--model)");
  std::error_code ec;
  if (!std::filesystem::is_regular_file(path, ec)) return fail(Status::BadArgument, path + ": no such file");
  cv::dnn::Net net;
  const QuietOpenCvLog quiet;
  try {
    net = cv::dnn::readNetFromONNX(path);
  } catch (const std::exception& e) {  // cv::Exception, or the protobuf parser's own
    return fail(Status::BadArgument, fmt::format("{}: cannot load the grasp network: {}", path, reasonOf(e.what())));
  }
  if (net.empty()) return fail(Status::BadArgument, path + ": cannot load the grasp network: OpenCV returned an empty network");
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  // One forward pass on a small input: a network that loads but is not a grasp network
  // (other input or output shape) is refused here, not on the first frame.
  try {
    net.setInput(cv::dnn::blobFromImage(cv::Mat::zeros(2 * kNetStride, 3 * kNetStride, CV_32FC1)));
    const cv::Mat out = net.forward();
    cv::Mat planes[4];
    if (!outputPlanes(out, 2 * kNetStride, 3 * kNetStride, planes))
      return fail(Status::BadArgument, fmt::format("{}: not a grasp network: a 1 x 1 x {} x {} input gave {}, expected 1 x 4 x {} x {}", path,
                                                   2 * kNetStride, 3 * kNetStride, shapeOf(out), 2 * kNetStride, 3 * kNetStride));
  } catch (const std::exception& e) {
    return fail(Status::BadArgument, fmt::format("{}: not a grasp network: a test input failed: {}", path, reasonOf(e.what())));
  }
  return std::unique_ptr<GraspDetector>(std::make_unique<GgcnnDetector>(std::move(net), o));
}

}  // namespace vgr::vision::grasp
