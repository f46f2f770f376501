// Reading an `!!opencv-matrix` node of a calibration file safely. OpenCV sizes the matrix
// from the node's own `rows`/`cols` before it reads `data`, so a damaged file ("rows: U3",
// "rows: 1000000000") could make it allocate gigabytes (found by fuzz_calib_files: a 48 GB
// request). readSmallMatrix checks the node first: rows and cols integers in [1, maxSide],
// `data` a sequence of exactly rows x cols numbers (one channel); only then OpenCV reads it.
// Thread: any (no state).
#pragma once

#include <opencv2/core/mat.hpp>
#include <opencv2/core/persistence.hpp>

namespace vgr::vision::calib {

// True and `out` (CV_64F) filled when `node` is such a matrix of exactly rows x cols;
// false (and `out` untouched) otherwise: absent, malformed, or another shape.
inline bool readSmallMatrix(const cv::FileNode& node, int rows, int cols, cv::Mat& out) {
  if (node.empty() || !node.isMap()) return false;
  const cv::FileNode r = node["rows"], c = node["cols"], d = node["data"];
  if (!r.isInt() || !c.isInt() || !d.isSeq()) return false;
  if (static_cast<int>(r) != rows || static_cast<int>(c) != cols) return false;
  if (d.size() != static_cast<std::size_t>(rows) * static_cast<std::size_t>(cols)) return false;
  for (const auto& v : d)
    if (!v.isReal() && !v.isInt()) return false;
  cv::Mat m;
  node >> m;
  if (m.rows != rows || m.cols != cols || m.channels() != 1) return false;
  m.convertTo(out, CV_64F);
  return true;
}

}  // namespace vgr::vision::calib
