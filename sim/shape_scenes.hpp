// Scenes of machined parts with many edges for the shape matcher's scale tests and the
// real-parts benchmark (vgr-bench-locate --scene gear|plate, docs/performance.md): a 24-tooth
// gear and a slotted plate, drawn as exact polygons (outline and holes) through a map
// part px -> image px that is a similarity (position, rotation, scale) optionally followed by
// a slight projective distortion (a mildly tilted camera), on a dark belt with clutter
// shapes, a linear lighting gradient and Gaussian noise.
//
// Units and conventions (vision/locate/locator.hpp): pixels, x right, y down, pixel centres
// at integers; angles in degrees, counter-clockwise as displayed. A part is given in "part
// px": template pixels at scale 1, its origin (the grasp point) at (0, 0). The truth of a
// placed part is the grasp point's image position and the local similarity of the map there
// (rotation and scale: the projective term has no first-order effect at the origin, so the
// truth is exact under perspective too).
//
// Anti-aliasing: each pixel gets the exact area of the part within it (a font rasteriser's
// coverage accumulation, shape_scenes.cpp), so the truth holds to float precision at any
// sub-pixel position. (fillPoly at 8x, as sim/scene.cpp draws, puts an axis-parallel edge on
// a 1/8 px grid and includes boundary samples: a template with its edges on pixel borders
// was then 0.1 px off its scenes.)
// Pure functions of their arguments and seeds; thread-safe.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/result.hpp"

namespace vgr::sim::shapes {

struct ShapePart {
  std::string name;
  std::vector<std::vector<cv::Point2d>> solids;  // part px, filled
  std::vector<std::vector<cv::Point2d>> holes;   // part px, inside the solids and apart: cut out (the belt shows)
  double radius = 0;                             // part px: farthest vertex from the origin
};

// A spur gear of `teeth` trapezoidal teeth (tip diameter `diameterPx`, module diameter /
// (teeth + 2)), a bore with a keyway and five lightening holes (5 and 24 share no factor: one
// pose only fits). Origin: the gear's axis.
ShapePart gear(double diameterPx, int teeth = 24);
// A plate `lengthPx` x 0.62 lengthPx with rounded corners, one chamfered corner, a notch in
// one long side, six slots in three directions and three round holes. Origin: the plate's
// centre.
ShapePart slottedPlate(double lengthPx);
// "gear" or "plate" at size `sizePx` (the gear's tip diameter, the plate's length).
Result<ShapePart> partByName(const std::string& name, double sizePx);

// Where a part lies in the image: the map p -> H(p) with
//   a = s R(angle) p   (R turns counter-clockwise as displayed: y is down),
//   H(p) = (u, v) + a / (1 + g . a)    (g = perspective, 1/px; (0, 0) = a pure similarity).
struct ShapePose {
  double u = 0, v = 0;       // px: the grasp point (the part's origin) in the image
  double angleDeg = 0;       // CCW as displayed
  double scale = 1;          // image px per part px
  cv::Point2d perspective;   // g, 1/px: |g| * radius is the relative change of scale across the part
};
cv::Point2d mapPoint(const ShapePose& pose, cv::Point2d p);

struct ShapeSceneOptions {
  cv::Size size{2448, 2048};    // px
  double noiseSigma = 5;        // gray levels, Gaussian
  double illumRatio = 1;        // >= 1: brightest : darkest corner of a linear lighting gradient (random direction)
  int clutter = 0;              // distractor shapes (rectangles, discs, triangles, bars) clear of the parts
  std::uint8_t background = 30;  // belt gray level
  std::uint8_t foreground = 185;  // part gray level (before lighting)
  std::uint64_t seed = 1;       // noise, clutter and gradient direction
};

// Draws the parts at `poses` (they must not overlap; the caller chooses) into dst (CV_8UC1,
// options.size).
void renderScene(const ShapePart& part, const std::vector<ShapePose>& poses, const ShapeSceneOptions& options,
                 cv::Mat& dst);

// The template: the part at scale 1, angle 0, no perspective, uniform light, noise sigma
// `noiseSigma` (seed), cropped to the part plus `marginPx`. graspU/V: the origin in template px.
struct ShapeTemplate {
  cv::Mat image;
  double graspU = 0, graspV = 0;
};
ShapeTemplate renderTemplate(const ShapePart& part, int marginPx, double noiseSigma, std::uint64_t seed,
                             std::uint8_t background = 30, std::uint8_t foreground = 185);

// `count` poses of one part each, uniform in position (the part, at the largest scale and with
// `marginPx`, inside the image), angle in [-angleRangeDeg, angleRangeDeg] and scale in
// [scaleMin, scaleMax]; perspective of magnitude `perspective` (1/px) in a random direction.
std::vector<ShapePose> randomPoses(const ShapePart& part, cv::Size size, int count, double angleRangeDeg,
                                   double scaleMin, double scaleMax, double perspective, int marginPx,
                                   std::uint64_t seed);

}  // namespace vgr::sim::shapes
