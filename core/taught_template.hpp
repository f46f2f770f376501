// What teaching a job produces besides the template image: the grasp point, the search
// region, thresholds, the contour regions of a multi-height part and the method's
// parameters (docs/localization.md "Jobs"). Plain data shared by config/ (job.yaml is read
// into it) and vision/ (the methods are built from it): no OpenCV, no YAML. vision/ keeps
// the names vgr::vision::PixelPoint, ... (using-declarations in vision/locate/locator.hpp
// and vision/calib/plane_model.hpp).
//
// Conventions (ARCHITECTURE.md "Units"): template pixels, x right, y down, pixel centres at
// integers; angles in degrees, counter-clockwise as displayed.
#pragma once

#include <map>
#include <string>
#include <vector>

namespace vgr {

struct PixelPoint {
  double u = 0, v = 0;  // px: x right, y down, pixel centres at integers
};

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

// Where a method parameter was written (file and 1-based line of its `params:` entry), so
// a method's range check can name it like the job reader does: "FILE:LINE: key 'params.x'".
struct ParamSource {
  std::string file;
  int line = 0;
};

// The scale range a job may search (TaughtTemplate::scaleMin/scaleMax), image px per template px.
inline constexpr double kMinPartScale = 0.2, kMaxPartScale = 5.0;

struct TaughtTemplate {
  PixelPoint grasp;                     // grasp point, template px
  PixelRect searchRoi;                  // where to search in live images; empty = whole image
  double minScore = 0.5;                // [0, 1]: weaker candidates are not parts
  int maxParts = 1;                     // [1, 64]: at most this many parts per image
  double angleMinDeg = -180, angleMaxDeg = 180;  // search range relative to the template
  // Scale range relative to the template (image px per template px), within
  // [kMinPartScale, kMaxPartScale], min <= max;
  // 1/1 = parts are seen as large as taught. A part seen larger is nearer the camera
  // (vision/part_poses.hpp maps it so); methods that search a range report each part's scale.
  double scaleMin = 1, scaleMax = 1;
  std::vector<TemplateRegion> regions;  // empty = the method splits its own (paper 000)
  // Method parameters from job.yaml, by name, as written there (the method parses and
  // range-checks them; an unknown name is an error naming it).
  std::map<std::string, std::string> params;
  // Where each of `params` was read from (loadJob fills it; empty for params set in code).
  std::map<std::string, ParamSource> paramSources;
};

}  // namespace vgr
