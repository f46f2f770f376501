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
// A depth frame's picture (vgrd's page for a 3D cycle, docs/3d.md "The page's depth picture")
// is the same picture on colourDepth()'s false-colour image: each 3D part (overlayPart3d)
// has its grasp frame's axes (x red, y green, z blue, with a dark outline) instead of the
// in-plane arrow, then the same magenta disc, label and caption; and a colour bar at the
// right edge says which z each colour stands for (near at the top, far at the bottom, mm).
// Conventions (docs/architecture.md "Units"): image px, x right, y down, pixel centres at
// integers; angles in degrees, counter-clockwise as displayed. Pure image code, any thread.
#pragma once

#include <array>
#include <optional>
#include <string>
#include <vector>

#include <opencv2/core.hpp>

#include "core/cycle.hpp"
#include "core/depth.hpp"
#include "core/pose.hpp"
#include "core/taught_template.hpp"
#include "vision/locate/locator.hpp"  // Detection

namespace vgr::vision {

struct OverlayPart {
  double u = 0, v = 0;   // grasp point, image px
  double angleDeg = 0;   // part rotation, CCW as displayed
  double score = 0;      // [0, 1]
  int label = 0;         // 0 = no class (not drawn)
  double confidence = 0; // [0, 1]: the classifier's confidence in `label` (drawn with it)
  // A 3D part (overlayPart3d): the image px of its grasp frame's x, y and z axis ends, drawn
  // from (u, v) in red, green and blue instead of the in-plane arrow.
  bool axes3d = false;
  std::array<cv::Point2d, 3> axisEnds{};
};

// The z range a depth picture's colours stand for, mm (near < far).
struct DepthColourRange {
  double nearMm = 0, farMm = 0;
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
  std::optional<DepthColourRange> depthRange;  // a depth picture: its colour bar (mm)
};

inline constexpr int kGraspRadiusPx = 7;  // output px

// gray: CV_8UC1 (or CV_8UC3, drawn on a copy). scale in (0, 1]: the output is the input
// resized by it (INTER_AREA). Returns CV_8UC3 BGR.
cv::Mat drawOverlay(const cv::Mat& gray, const OverlayFrame& frame, double scale = 1.0);

// The parts of a locator's output (`vgr locate`, `vgr eval`) and of a cycle's result
// (vgrd), in their order.
std::vector<OverlayPart> overlayParts(const std::vector<Detection>& found);
std::vector<OverlayPart> overlayParts(const std::vector<PartResult>& parts);
// A depth frame (CV_32FC1, z in mm, 0 or NaN = no data) as a false-colour picture into `bgr`
// (CV_8UC3, the frame's size; its buffer is reused): cv::COLORMAP_TURBO from dark red at
// `near` to dark blue at `far`, pixels without data black. near / far are the 0.5th and
// 99.5th percentiles of the frame's valid z (a 1024-bin histogram: a few stray pixels do not
// squash the colours; z outside is drawn in the end colours); a frame whose valid z all lie
// within 1 mm gets [z - 0.5, z + 0.5]. nullopt (and `bgr` all black) without a valid pixel.
// Not the hot path: it allocates a mask and a histogram.
std::optional<DepthColourRange> colourDepth(const cv::Mat& depthMm, cv::Mat& bgr);
// The BGR colour colourDepth gives z (in the end colours outside the range).
cv::Vec3b depthColour(double zMm, const DepthColourRange& range);

// A part found in a depth frame: T_cam_grasp (mm, camera frame: x right, y down, z forward)
// projected with the frame's pinhole intrinsics: the grasp point at (u, v) and its axes
// `axisMm` long. A grasp point at z <= 0 (behind the camera) is drawn nowhere (u = v = -1e6).
OverlayPart overlayPart3d(const Pose& camFromGrasp, const DepthIntrinsics& k, double score, double axisMm = 40);

// "cycle 17  job 1  OK  2 parts" (or "cycle 18  job 1  -4 CAMERA_ERROR").
std::string cycleCaption(std::uint32_t cycleId, int jobId, Status status, std::size_t parts);

// The scale that fits an image of `width` px into `maxWidth` (1 when it already fits).
double overlayScaleFor(int width, int maxWidth);

}  // namespace vgr::vision
