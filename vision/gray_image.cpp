#include "vision/gray_image.hpp"

#include <string>

#include <opencv2/imgcodecs.hpp>

namespace vgr::vision {

void toGray8(const cv::Mat& samples, int bitDepth, cv::Mat& gray8) {
  if (samples.depth() == CV_8U) {
    gray8 = samples;
    return;
  }
  samples.convertTo(gray8, CV_8UC1, 1.0 / (1 << (bitDepth - 8)));
}

cv::Mat toFullRange16(const cv::Mat& samples, int bitDepth) {
  if (samples.depth() == CV_8U || bitDepth >= 16) return samples;
  cv::Mat out;
  samples.convertTo(out, CV_16UC1, static_cast<double>(1 << (16 - bitDepth)));  // exact: a shift
  return out;
}

Result<cv::Mat> readGray8(const std::string& path) {
  // ANYDEPTH keeps 16-bit samples (IMREAD_GRAYSCALE alone would truncate them to their top
  // byte, not round as vgrd does).
  cv::Mat m = cv::imread(path, cv::IMREAD_GRAYSCALE | cv::IMREAD_ANYDEPTH);
  if (m.empty()) return fail(Status::BadArgument, path + ": cannot read the image");
  if (m.depth() == CV_8U) return m;
  if (m.depth() != CV_16U) return fail(Status::BadArgument, path + ": expected an 8- or 16-bit gray image");
  // Full range means a frame of any brightness reaches above 1/16 of it. Every sample below
  // 4096 is LSB-aligned Mono10/12 data (another tool's save): read as full range it would be
  // black (at most 16 of 255) and nothing found, with no word why.
  double hi = 0;
  cv::minMaxLoc(m, nullptr, &hi);
  if (hi < 4096)
    return fail(Status::BadArgument,
                path + ": a 16-bit image whose samples all lie in 0.." + std::to_string(static_cast<int>(hi)) +
                    " (<= 4095): LSB-aligned Mono10/12 samples, not the full-range 16 bits vgr reads (vgr grab --save "
                    "writes them so); scale it by 2^(16 - bits) first");
  cv::Mat gray8;
  toGray8(m, 16, gray8);
  return gray8;
}

}  // namespace vgr::vision
