// Reading an `!!opencv-matrix` node of a calibration file safely. OpenCV sizes the matrix
// from the node's own `rows`/`cols` before it reads `data`, so a damaged file ("rows: U3",
// "rows: 1000000000") could make it allocate gigabytes (found by fuzz_calib_files: a 48 GB
// request). readSmallMatrix checks the node first: rows and cols integers in [1, maxSide],
// `data` a sequence of exactly rows x cols numbers (one channel); only then OpenCV reads it.
// Thread: any (no state).
#pragma once

#include <fstream>
#include <stdexcept>
#include <string>

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

// Throws std::runtime_error unless the file begins with "%YAML", as every calibration file
// vgr writes does. cv::FileStorage picks its parser by the content, and OpenCV 4.6's XML
// parser dereferences null on a truncated "<?xml" text (found by fuzz_calib_files: a SEGV
// inside cv::FileStorage::Impl::open); such a file never reaches OpenCV now. Call inside
// the reader's try block: the reader turns the exception into its own NOT_CALIBRATED error.
inline void requireYamlText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  char head[5] = {};
  if (in.read(head, sizeof head) && std::string(head, sizeof head) == "%YAML") return;
  throw std::runtime_error("not a calibration file as vgr writes it (it must begin with %YAML)");
}

}  // namespace vgr::vision::calib
