// Shape features of one found part (paper 002 Sec. 3, "Identification"): the part's blob is
// segmented by a global threshold (the paper's "standard thresholding", Sec. 3 preprocessing),
// its outer and inner contours taken (findContours, RETR_CCOMP: paper 002's external and
// internal contours), and a fixed-length vector computed from them:
//   [0..6]  Hu moments h1..h7 of the blob (holes excluded), each as sign(h) * log10(1 + |h|/1e-9):
//           paper 002 eq. 1 (sign(h) log|h|, the form matchShapes compares in eqs. 2-4) made
//           continuous at h = 0, where symmetric parts' h3..h7 sit
//   [7]     log10 area, px²        (zero-order moment M00, eq. 12)
//   [8]     log10 outer perimeter, px (of the contour simplified to 1 px: rotation invariant)
//   [9]     compactness 4*pi*A / P² (1 for a disc)
//   [10]    elongation: short / long side of the minimum-area rectangle
//   [11]    solidity: area / convex hull area
//   [12]    number of holes (inner contours of at least kMinHoleAreaPx)
//   [13]    hole area / (area + hole area)
// Paper 002's MLP itself was fed resized, flattened crops (Sec. 3, "MLP classifier"); these
// are the shape measures the paper uses elsewhere (Hu moments, moments, contours), which
// make a small network that trains in seconds and is invariant to rotation (docs/classification.md).
//
// Pixels: image px, x right, y down. Pure image code, any thread, no state.
#pragma once

#include <array>
#include <vector>

#include "core/result.hpp"

namespace cv {
class Mat;
}

namespace vgr::vision::classify {

inline constexpr int kFeatureCount = 14;
inline constexpr double kMinHoleAreaPx = 12;
using FeatureVector = std::array<float, kFeatureCount>;

// The names of the features in FeatureVector order (docs, `vgr classify` reports).
const std::array<const char*, kFeatureCount>& featureNames();

// One segmented blob: its features and where it is.
struct PartBlob {
  FeatureVector features{};
  double cx = 0, cy = 0;  // centroid, image px (eq. 12)
  double areaPx = 0;
  int label = 0;          // index into the label image segmentParts() filled (1-based)
};


// Features of the blob given as a filled CV_8UC1 mask (non-zero = part, holes zero).
// Errors: Status::BadArgument for a wrong type or an empty mask.
Result<FeatureVector> maskFeatures(const cv::Mat& mask);

// Thresholds gray (CV_8UC1, parts bright on dark; threshold 0 = Otsu) and returns every
// outer blob of at least minAreaPx that does not touch the image border, with its features.
Result<std::vector<PartBlob>> segmentParts(const cv::Mat& gray, int threshold, double minAreaPx);

}  // namespace vgr::vision::classify
