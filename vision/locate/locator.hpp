// The one interface every localization method implements (docs/localization.md, docs/shape-matcher.md), and the factory
// that builds a method's model from a taught template.
//
// Conventions (docs/architecture.md "Units"): image pixels, x right, y down, pixel centres
// at integers. A Detection's (u, v) is the job's grasp point transferred into the live
// image; angleDeg is the part's rotation relative to the template, counter-clockwise as
// displayed (so a part turned like the template reads 0), in (-180, 180].
//
// Threads: a Locator is built once per job and used by one thread at a time (it may keep
// scratch buffers between calls; no allocation per image after the first is the goal).
// Building (makeLocator) may be slow (pre-rotated models, pyramids); locate() is the hot path.
#pragma once

#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.hpp"
#include "core/taught_template.hpp"  // PixelPoint, PixelRect, TemplateRegion, TaughtTemplate
#include "vision/calib/plane_model.hpp"  // PixelPoint (vision::)

namespace cv {
class Mat;
}

namespace vgr::vision {

// Plain teaching data (core/taught_template.hpp), under the names vision has always used.
using vgr::PixelRect;
using vgr::TaughtTemplate;
using vgr::TemplateRegion;

struct Detection {
  double u = 0, v = 0;    // grasp point in the live image, px
  double angleDeg = 0;    // rotation from the template, CCW as displayed, (-180, 180]
  double scale = 1;       // image px per template px (1 for a method or job without a scale range)
  double score = 0;       // [0, 1], method specific, comparable against minScore
  double areaPx = 0;      // px², 0 when the method does not measure it
  int label = 0;          // which part type / template (0 = the job's one template, or "unknown"
                          // when the job has a classifier: vision/classify/classifying_locator.hpp)
  double confidence = 0;  // [0, 1]: the classifier's confidence in `label`; 0 without a classifier
};

// One accepted feature correspondence (feature methods only), for paper 001's match
// true-positive rate in `vgr eval`.
struct MatchPair {
  PixelPoint templatePx;
  PixelPoint imagePx;
};

struct LocateOutput {
  std::vector<Detection> parts;    // best score first; empty = no part (status 1), not an error
  std::vector<MatchPair> matches;  // feature methods: the matches the best part was accepted on
  int candidateMatches = 0;        // feature methods: matches before filtering
};

class Locator {
 public:
  virtual ~Locator() = default;
  virtual std::string_view method() const = 0;
  // gray: CV_8UC1 live image. Errors only for bad input (wrong type) or internal failure.
  virtual Result<LocateOutput> locate(const cv::Mat& gray) = 0;
};

// Builds `method`'s model from the template (CV_8UC1, the part as taught). Errors carry
// Status::BadArgument and name the method and the parameter at fault.
Result<std::unique_ptr<Locator>> makeLocator(std::string_view method, const cv::Mat& templateGray,
                                             const TaughtTemplate& taught);

// The method names makeLocator() accepts, in the order `vgr` lists them.
const std::vector<std::string>& locatorMethods();

}  // namespace vgr::vision
