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

#include <map>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

#include "core/result.hpp"
#include "vision/calib/plane_model.hpp"  // PixelPoint

namespace cv {
class Mat;
}

namespace vgr::vision {

struct PixelRect {
  int x = 0, y = 0, width = 0, height = 0;  // px
  bool empty() const { return width <= 0 || height <= 0; }
};

// A contour region of a multi-height part (paper 000, eqs. 3-4): a polygon in template
// pixels, its height above the conveyor plane (mm, 0 = on the plane) and the height factor
// h_i of eq. 4 (1 = the grasp point's level).
struct TemplateRegion {
  std::vector<PixelPoint> polygon;  // template px, closed implicitly
  double heightMm = 0;
  double heightFactor = 1;
};

// What teaching produced, besides the template image itself.
struct TaughtTemplate {
  PixelPoint grasp;                     // grasp point, template px
  PixelRect searchRoi;                  // where to search in live images; empty = whole image
  double minScore = 0.5;                // [0, 1]: weaker candidates are not parts
  int maxParts = 1;                     // [1, 64]: at most this many parts per image
  double angleMinDeg = -180, angleMaxDeg = 180;  // search range relative to the template
  std::vector<TemplateRegion> regions;  // empty = the method splits its own (paper 000)
  // Method parameters from job.yaml, by name, as written there (the method parses and
  // range-checks them; an unknown name is an error naming it).
  std::map<std::string, std::string> params;
};

struct Detection {
  double u = 0, v = 0;    // grasp point in the live image, px
  double angleDeg = 0;    // rotation from the template, CCW as displayed, (-180, 180]
  double score = 0;       // [0, 1], method specific, comparable against minScore
  double areaPx = 0;      // px², 0 when the method does not measure it
  int label = 0;          // which part type / template (0 = the job's one template)
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
