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
#include "vision/locate/input_check.hpp"
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

// The method registry: one explicit table (STYLE.md rule 3, like drivers/registry.cpp), in
// the order `vgr` lists the methods.
struct MethodEntry {
  std::string_view name;
  Result<std::unique_ptr<Locator>> (*make)(const cv::Mat& templateGray, const TaughtTemplate& taught);
};
constexpr MethodEntry kMethods[] = {
    {"moments", makeMomentsLocator},
    {"hu", makeHuLocator},
    {"sift", makeSiftLocator},
    {"orb-ransac", makeOrbRansacLocator},
    {"orb-prosac", makeOrbProsacLocator},
    {"orb-adk", makeOrbAdkLocator},
    {"contour-weighted", makeContourWeightedLocator},
    {"shape", makeShapeLocator},
};

}  // namespace

Result<std::unique_ptr<Locator>> makeLocator(std::string_view method, const cv::Mat& templateGray,
                                             const TaughtTemplate& taught) {
  if (templateGray.empty() || templateGray.type() != CV_8UC1)
    return fail(Status::BadArgument, fmt::format("{}: the template must be a non-empty 8-bit gray image", method));
  if (taught.maxParts < 1 || taught.maxParts > 64)
    return fail(Status::BadArgument, fmt::format("{}: max_parts must be in [1, 64], got {}", method, taught.maxParts));
  for (const auto& m : kMethods)
    if (m.name == method) {
      auto made = m.make(templateGray, taught);
      if (!made) return made;
      return withInputChecks(std::move(*made), templateGray.size(), taught.searchRoi);
    }
  std::string known;
  for (const auto& m : locatorMethods()) known += (known.empty() ? "" : ", ") + m;
  return fail(Status::BadArgument, fmt::format("unknown locate method '{}' (known: {})", method, known));
}

const std::vector<std::string>& locatorMethods() {
  static const std::vector<std::string> kNames = [] {
    std::vector<std::string> names;
    for (const auto& m : kMethods) names.emplace_back(m.name);
    return names;
  }();
  return kNames;
}

}  // namespace vgr::vision
