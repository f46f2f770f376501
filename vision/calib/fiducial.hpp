// A fixed fiducial for calibration checks (docs/calibration.md, "Checking a calibration"):
// a round mark (a bright disk on the darker belt or frame, or a dark one on a bright
// ground) glued where the camera always sees it. locateFiducial() finds it in a search
// window of the image and returns its centre with sub-pixel precision; the drift monitor
// (daemon/drift_monitor.hpp) and `vgr calibrate verify` map that centre with the cell's
// calibration and compare it with the stored position.
//
// Method: Otsu threshold inside the window; connected components; the mark is the one
// component that does not touch the window's border, is round (area >= 70 % of the circle
// over its bounding box, aspect within 0.75..1.33), stands out from the ground by at least
// `minContrast` gray levels and, when `expectedAreaPx` is set, has an area within 40 % of
// it. Its centre is the gray-weighted centroid (weights: gray level above the threshold)
// over its bounding box grown by 2 px, which averages the edge pixels instead of rounding
// them (a binary centroid moves in steps of the edge's pixels). None or more than one
// such component: an error saying which ("not seen": a part lying on it, the camera moved
// so far that it left the window). Pure; any thread; allocates per call (a few KB).
#pragma once

#include <opencv2/core.hpp>

#include "core/result.hpp"
#include "core/taught_template.hpp"  // PixelPoint

namespace vgr::vision::calib {

struct FiducialSearch {
  cv::Rect window;             // px, where to look (clipped to the image)
  bool bright = true;          // true: a bright mark on a darker ground
  double expectedAreaPx = 0;   // px²; 0 = any area of at least minAreaPx
  double minAreaPx = 12;       // px²
  double minContrast = 20;     // gray levels between the mark's mean and the ground's
};

struct FiducialFound {
  PixelPoint centre;   // px
  double areaPx = 0;   // px² of the thresholded blob
  double diameterPx = 0;  // of the circle with that area
};

// gray: CV_8UC1. Errors: Status::NoPartFound with the reason.
Result<FiducialFound> locateFiducial(const cv::Mat& gray, const FiducialSearch& search);

}  // namespace vgr::vision::calib
