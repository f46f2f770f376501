// The overlay picture of one located image: what the commissioning page shows (vgrd's web
// page, the live image and archived cycles), what `vgr locate --overlay` and
// `vgr eval --overlays` write. One function draws all of them, so the three pictures of
// the same image and result are the same picture (docs/commissioning.md).
//
// Drawn on a colour copy of the gray image (optionally scaled, coordinates scaled with it,
// lines and text sized for the output, not the input):
//   - the search ROI: a yellow rectangle (BGR 0,220,255) on its boundary pixels, when the job has one;
//   - each part: its template's outline turned by the part's angle about the grasp point
//     (green, when the template size is known), the part's axis (green arrow, 0 deg = the
//     template's +x, counter-clockwise as displayed), and the grasp point: a filled magenta
//     disc (BGR 255,0,255, radius kGraspRadiusPx in the output) with a white rim. Tests
//     (the browser test) look for the magenta disc at (u, v) on the page's canvas;
//   - a label by each part: "#<rank> <score>" and " L<label> <confidence>" when the part has a class;
//   - a caption banner on top: e.g. "cycle 17  job 1  OK  2 parts", green text for OK,
//     red otherwise.
// Conventions (docs/architecture.md "Units"): image px, x right, y down, pixel centres at
// integers; angles in degrees, counter-clockwise as displayed. Pure image code, any thread.
#pragma once

#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/cycle.hpp"
#include "core/taught_template.hpp"
#include "vision/locate/locator.hpp"  // Detection

namespace vgr::vision {

struct OverlayPart {
  double u = 0, v = 0;   // grasp point, image px
  double angleDeg = 0;   // part rotation, CCW as displayed
  double score = 0;      // [0, 1]
  int label = 0;         // 0 = no class (not drawn)
  double confidence = 0; // [0, 1]: the classifier's confidence in `label` (drawn with it)
};

struct OverlayJob {
  PixelRect searchRoi;          // empty = the whole image (not drawn)
  int templateWidth = 0;        // px; 0 = unknown (no outline, only the grasp point and axis)
  int templateHeight = 0;
  PixelPoint templateGrasp;     // grasp point in template px
};

struct OverlayFrame {
  OverlayJob job;
  std::vector<OverlayPart> parts;  // best first (rank 1 = first)
  std::string caption;             // banner text; empty = no banner
  bool ok = true;                  // caption colour: green (true) or red
};

inline constexpr int kGraspRadiusPx = 7;  // output px

// gray: CV_8UC1 (or CV_8UC3, drawn on a copy). scale in (0, 1]: the output is the input
// resized by it (INTER_AREA). Returns CV_8UC3 BGR.
cv::Mat drawOverlay(const cv::Mat& gray, const OverlayFrame& frame, double scale = 1.0);

// The parts of a locator's output (`vgr locate`, `vgr eval`) and of a cycle's result
// (vgrd), in their order.
std::vector<OverlayPart> overlayParts(const std::vector<Detection>& found);
std::vector<OverlayPart> overlayParts(const std::vector<PartResult>& parts);
// "cycle 17  job 1  OK  2 parts" (or "cycle 18  job 1  -4 CAMERA_ERROR").
std::string cycleCaption(std::uint32_t cycleId, int jobId, Status status, std::size_t parts);

// The scale that fits an image of `width` px into `maxWidth` (1 when it already fits).
double overlayScaleFor(int width, int maxWidth);

}  // namespace vgr::vision
