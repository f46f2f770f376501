// What a calibration file must be before OpenCV parses it (requireYamlText) and reading an
// `!!opencv-matrix` node of one safely (readSmallMatrix). OpenCV sizes the matrix
// from the node's own `rows`/`cols` before it reads `data`, so a damaged file ("rows: U3",
// "rows: 1000000000") could make it allocate gigabytes (found by fuzz_calib_files: a 48 GB
// request). readSmallMatrix checks the node first: rows and cols integers in [1, maxSide],
// `data` a sequence of exactly rows x cols numbers (one channel); only then OpenCV reads it.
// Thread: any (no state).
#pragma once

#include <cstddef>
#include <fstream>
#include <iterator>
#include <stdexcept>
#include <string>

#include <opencv2/core/mat.hpp>
#include <opencv2/core/persistence.hpp>
#include <yaml-cpp/yaml.h>

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

// Throws std::runtime_error unless the file looks like what vgr writes: it begins with
// "%YAML", it is text (no control bytes but tab, CR, LF), no line after the header starts
// with "--" other than the "---" document marker, and the rest is well-formed YAML with a
// map at its top (checked with yaml-cpp). cv::FileStorage picks its parser by the
// content, and OpenCV 4.6's parsers fail badly on damaged text (found by fuzz_calib_files):
// the XML parser dereferences null on a truncated "<?xml", the YAML parser loops without end
// on a run of dashes after the header. Such a file never reaches OpenCV now. Call inside the
// reader's try block: the reader turns the exception into its own NOT_CALIBRATED error.
inline void requireYamlText(const std::string& path) {
  std::ifstream in(path, std::ios::binary);
  std::string text((std::istreambuf_iterator<char>(in)), std::istreambuf_iterator<char>());
  if (text.rfind("%YAML", 0) != 0)
    throw std::runtime_error("not a calibration file as vgr writes it (it must begin with %YAML)");
  int line = 1;
  for (std::size_t i = 0; i < text.size(); ++i) {
    const unsigned char c = static_cast<unsigned char>(text[i]);
    if (c < 0x20 && c != '\t' && c != '\n' && c != '\r')
      throw std::runtime_error("line " + std::to_string(line) + ": a control byte: not a text file");
    if (c != '\n') continue;
    ++line;
    if (text.compare(i + 1, 2, "--") == 0 && text.compare(i + 1, 4, "---\n") != 0 && text.compare(i + 1, 5, "---\r\n") != 0)
      throw std::runtime_error("line " + std::to_string(line) + ": a line of dashes that is not the '---' marker");
  }
  // What follows the %YAML line must be well-formed YAML whose top level is a map, as
  // yaml-cpp (a parser fuzzed upstream) reads it. OpenCV's own parser loops without end on
  // some damaged text that is no map at all (fuzz_calib_files, 2026-12-05: "  -ion^ ]/"
  // lines, a timeout in readMultiHeight); such text never reaches it now. ("%YAML:1.0" is
  // OpenCV's form of the directive, which yaml-cpp does not take: the line is skipped.)
  const std::size_t nl = text.find('\n');
  YAML::Node root;
  try {
    root = YAML::Load(nl == std::string::npos ? std::string() : text.substr(nl + 1));
  } catch (const YAML::Exception& e) {
    throw std::runtime_error("line " + std::to_string(e.mark.line + 2) + ": not well-formed YAML: " + e.msg);
  }
  if (!root.IsMap()) throw std::runtime_error("not a calibration file: its top level is not a map of keys");
}

}  // namespace vgr::vision::calib
