#include "vision/locate/locator.hpp"

#include <fmt/core.h>

#include <opencv2/core.hpp>

#include "vision/locate/contour_weighted_locator.hpp"
#include "vision/locate/hu_sift_locators.hpp"
#include "vision/locate/input_check.hpp"
#include "vision/locate/moments_locator.hpp"
#include "vision/locate/orb_adk_locator.hpp"
#include "vision/locate/orb_homography_locator.hpp"
#include "vision/locate/shape_matcher.hpp"

namespace vgr::vision {

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
