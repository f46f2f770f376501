#include "vision/locate/locator.hpp"

#include <charconv>
#include <cmath>
#include <fmt/core.h>
#include <numbers>

#include <opencv2/core.hpp>

#include "core/angles.hpp"
#include "core/did_you_mean.hpp"
#include "vision/locate/contour_weighted_locator.hpp"
#include "vision/locate/hu_sift_locators.hpp"
#include "vision/locate/moments_locator.hpp"
#include "vision/locate/orb_adk_locator.hpp"
#include "vision/locate/orb_homography_locator.hpp"
#include "vision/locate/params.hpp"
#include "vision/locate/shape_matcher.hpp"

namespace vgr::vision {

// ---- ParamReader ----

double ParamReader::number(const std::string& name, double fallback, double lo, double hi) {
  used_.insert(name);
  const auto it = params_.find(name);
  if (it == params_.end()) return fallback;
  const std::string& s = it->second;
  double v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || !std::isfinite(v) || v < lo || v > hi) {
    setError(name, fmt::format("a number in [{}, {}]", lo, hi), s);
    return fallback;
  }
  return v;
}

int ParamReader::integer(const std::string& name, int fallback, int lo, int hi) {
  used_.insert(name);
  const auto it = params_.find(name);
  if (it == params_.end()) return fallback;
  const std::string& s = it->second;
  int v = 0;
  const auto [end, ec] = std::from_chars(s.data(), s.data() + s.size(), v);
  if (ec != std::errc{} || end != s.data() + s.size() || v < lo || v > hi) {
    setError(name, fmt::format("an integer in [{}, {}]", lo, hi), s);
    return fallback;
  }
  return v;
}

bool ParamReader::flag(const std::string& name, bool fallback) {
  used_.insert(name);
  const auto it = params_.find(name);
  if (it == params_.end()) return fallback;
  if (it->second == "true") return true;
  if (it->second == "false") return false;
  setError(name, "true or false", it->second);
  return fallback;
}

void ParamReader::setError(const std::string& name, const std::string& expected, const std::string& got) {
  if (error_.empty())
    error_ = fmt::format("{}: parameter '{}': expected {}, got '{}'{}", method_, name, expected, got, whereWritten(name));
}

std::string ParamReader::whereWritten(const std::string& name) const {
  const auto it = sources_.find(name);
  if (it == sources_.end()) return "";
  return fmt::format(" ({}:{}: key 'params.{}')", it->second.file, it->second.line, name);
}

Result<void> ParamReader::finish() const {
  if (!error_.empty()) return fail(Status::BadArgument, error_);
  for (const auto& [name, value] : params_)
    if (!used_.contains(name)) {
      const std::string best = closestName(name, used_);
      return fail(Status::BadArgument, fmt::format("{}: unknown parameter '{}'{}{}", method_, name,
                                                   best.empty() ? "" : " (did you mean '" + best + "'?)", whereWritten(name)));
    }
  return {};
}

namespace {

// "moments" with a template: the template's own blob gives the reference centroid and axis;
// a live blob's rotation is its axis minus the template's, and the grasp point is the
// template's grasp offset from the centroid turned by that rotation (y down, so a
// counter-clockwise turn as displayed by a is (x, y) -> (x cos a + y sin a, -x sin a + y cos a)).
class MomentsLocator final : public Locator {
 public:
  MomentsLocator(MomentsParams params, Detection reference, const TaughtTemplate& taught)
      : params_(params), reference_(reference), taught_(taught) {}

  std::string_view method() const override { return "moments"; }

  Result<LocateOutput> locate(const cv::Mat& gray) override {
    if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "moments: expected a non-empty 8-bit gray image");
    cv::Rect roi(0, 0, gray.cols, gray.rows);
    if (!taught_.searchRoi.empty())
      roi &= cv::Rect(taught_.searchRoi.x, taught_.searchRoi.y, taught_.searchRoi.width, taught_.searchRoi.height);
    auto found = locateByMoments(gray(roi), params_);
    if (!found) return std::unexpected(found.error());
    LocateOutput out;
    const double gx = taught_.grasp.u - reference_.u, gy = taught_.grasp.v - reference_.v;
    for (const Detection& d : *found) {
      if (d.score < taught_.minScore) continue;
      const double rot = normaliseDeg(d.angleDeg - reference_.angleDeg);
      if (rot < taught_.angleMinDeg || rot > taught_.angleMaxDeg) continue;
      const double a = rot * std::numbers::pi / 180.0;
      Detection p = d;
      p.u = roi.x + d.u + gx * std::cos(a) + gy * std::sin(a);
      p.v = roi.y + d.v - gx * std::sin(a) + gy * std::cos(a);
      p.angleDeg = rot;
      out.parts.push_back(p);
      if (static_cast<int>(out.parts.size()) >= taught_.maxParts) break;
    }
    return out;
  }

 private:
  MomentsParams params_;
  Detection reference_;
  TaughtTemplate taught_;
};

Result<std::unique_ptr<Locator>> makeMoments(const cv::Mat& templateGray, const TaughtTemplate& taught) {
  ParamReader r("moments", taught);
  MomentsParams p;
  p.threshold = r.integer("threshold", 0, 0, 255);
  p.minAreaPx = r.number("min_area_px", p.minAreaPx, 1, 1e9);
  p.maxAreaPx = r.number("max_area_px", p.maxAreaPx, 1, 1e9);
  if (auto ok = r.finish(); !ok) return std::unexpected(ok.error());
  if (p.maxAreaPx <= p.minAreaPx) return fail(Status::BadArgument, "moments: parameter 'max_area_px' must exceed 'min_area_px'");
  auto ref = locateByMoments(templateGray, p);
  if (!ref) return std::unexpected(ref.error());
  if (ref->empty()) return fail(Status::BadArgument, "moments: no part found in the template image (check threshold and area limits)");
  return std::make_unique<MomentsLocator>(p, ref->front(), taught);
}

}  // namespace

Result<std::unique_ptr<Locator>> makeLocator(std::string_view method, const cv::Mat& templateGray,
                                             const TaughtTemplate& taught) {
  if (templateGray.empty() || templateGray.type() != CV_8UC1)
    return fail(Status::BadArgument, fmt::format("{}: the template must be a non-empty 8-bit gray image", method));
  if (taught.maxParts < 1 || taught.maxParts > 64)
    return fail(Status::BadArgument, fmt::format("{}: max_parts must be in [1, 64], got {}", method, taught.maxParts));
  // One line per method; keep the order of locatorMethods().
  if (method == "moments") return makeMoments(templateGray, taught);
  if (method == "hu") return makeHuLocator(templateGray, taught);
  if (method == "sift") return makeSiftLocator(templateGray, taught);
  if (method == "orb-ransac") return makeOrbRansacLocator(templateGray, taught);
  if (method == "orb-prosac") return makeOrbProsacLocator(templateGray, taught);
  if (method == "orb-adk") return makeOrbAdkLocator(templateGray, taught);
  if (method == "contour-weighted") return makeContourWeightedLocator(templateGray, taught);
  if (method == "shape") return makeShapeLocator(templateGray, taught);
  std::string known;
  for (const auto& m : locatorMethods()) known += (known.empty() ? "" : ", ") + m;
  return fail(Status::BadArgument, fmt::format("unknown locate method '{}' (known: {})", method, known));
}

const std::vector<std::string>& locatorMethods() {
  static const std::vector<std::string> kMethods{"moments", "hu", "sift", "orb-ransac", "orb-prosac", "orb-adk", "contour-weighted", "shape"};
  return kMethods;
}

}  // namespace vgr::vision
