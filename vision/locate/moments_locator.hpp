// Method "moments" (paper 002): segmentation, then the centroid from the image moments
// (eq. 12) and the orientation from the second-order central moments (eq. 13), made
// unambiguous over 360 degrees by the sign of the third-order moment along the major axis.
// Pure image code: call from any one thread per instance; no allocation is retained.
#pragma once

#include <memory>
#include <vector>

#include "core/result.hpp"
#include "vision/locate/blob_polarity.hpp"
#include "vision/locate/locator.hpp"

namespace cv {
class Mat;
}

namespace vgr::vision {

struct MomentsParams {
  int threshold = 0;        // gray level [0, 255]; 0 = Otsu
  double minAreaPx = 2000;  // px²: smaller blobs are ignored (dust, noise)
  double maxAreaPx = 1e7;   // px²: larger blobs are ignored (glare, a belt seam)
  BlobSense sense = BlobSense::Bright;  // which side of the threshold is the part (blob_polarity.hpp)
};

// gray: 8-bit single channel, parts on the params.sense side of the threshold (bright on a dark
// background by default). Parts touching the image
// border are skipped (their moments would be wrong). Returns detections best score first;
// an empty list means no part (not an error). Here (u, v) is the blob's centroid and angleDeg
// the direction of its major axis in the image (not yet relative to a template: MomentsLocator
// in locator.cpp does that). Errors: Status::BadArgument for a wrong image type.
Result<std::vector<Detection>> locateByMoments(const cv::Mat& gray, const MomentsParams& params);

// Method "moments" of a taught job: the template's own blob is the reference (params
// "threshold", "min_area_px", "max_area_px", "polarity" (use | ignore_global: the template's
// sense, or either; blob_polarity.hpp) from job.yaml). A live blob is a part only if
// its shape is the template blob's: area within "area_tolerance" (relative, default 0.25)
// and compactness (Hu's first invariant, relative), anisotropy and skewness along the major
// axis (absolute) within "shape_tolerance" (default 0.1); other shapes are no part.
Result<std::unique_ptr<Locator>> makeMomentsLocator(const cv::Mat& templateGray, const TaughtTemplate& taught);

// An untaught job (cell config keys threshold / min_area_px / max_area_px, no folder): every
// blob in the area range is a part, its centroid the grasp point, its major axis the angle.
std::unique_ptr<Locator> makeUntaughtMomentsLocator(const MomentsParams& params);

}  // namespace vgr::vision
