// Polarity of the segmentation methods `moments` and `hu` (paper 002): which side of the
// global threshold is the part. The job's `polarity` parameter takes the shape matcher's
// words (shape_matcher.hpp, docs/shape-matcher.md):
//   use           the part has the template's sense: bright on a dark belt, or dark on a
//                 light one, read from the template (the side of the threshold its border,
//                 the belt around the taught part, is not on). Default.
//   ignore_global the whole part may be inverted: blobs of both senses are candidates.
//   ignore_local  refused: a blob is one region, it cannot be inverted edge by edge.
// Pure functions; any thread.
#pragma once

#include <string>

#include "core/result.hpp"

namespace cv {
class Mat;
}

namespace vgr::vision {

class ParamReader;

enum class BlobSense {
  Bright,  // the part is above the threshold (THRESH_BINARY)
  Dark,    // the part is at or below it (THRESH_BINARY_INV)
  Either,  // both: polarity ignore_global
};

// The template's sense: Dark when most of its 1-px border lies above the threshold
// (threshold > 0: that gray level, 0: Otsu's on the template), else Bright.
BlobSense templateSense(const cv::Mat& templateGray, int threshold);

// Reads parameter "polarity" (use | ignore_global) through `reader` and returns the sense
// live images are segmented with. A bad word is left in the reader's error (finish()).
BlobSense readBlobPolarity(ParamReader& reader, const cv::Mat& templateGray, int threshold);

// The binary image of one sense (Bright or Dark) at `threshold` (0 = Otsu), 255 = part.
void segment(const cv::Mat& gray, int threshold, BlobSense sense, cv::Mat& binary);

// "bright" / "dark" / "either", for messages.
const char* senseName(BlobSense sense);

}  // namespace vgr::vision
