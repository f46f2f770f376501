// Automatic contour regions for teaching (paper 000, Sec. III-B and Fig. 5): the template's
// significant-gradient contours, split into connected pieces, each a region polygon. Heights
// are unknown from one image, so every region gets height 0 and height factor 1; the user
// (or `vgr teach --regions`) sets the factors of regions at other heights than the grasp
// point (eq. 4: "far less than 1"). Pure image code.
#pragma once

#include <vector>

#include "vision/locate/locator.hpp"

namespace cv {
class Mat;
}

namespace vgr::vision {

// templateGray: CV_8UC1. At most maxRegions regions, largest contours first; pieces shorter
// than minLengthPx are dropped (noise, text). Polygons are the convex hulls of the pieces.
std::vector<TemplateRegion> splitTemplateRegions(const cv::Mat& templateGray, int maxRegions = 12, double minLengthPx = 40);

}  // namespace vgr::vision
