#include "vision/depth_image.hpp"

#include <fmt/core.h>
#include <opencv2/imgcodecs.hpp>

namespace vgr::vision {
namespace {

const char* depthName(int depth) {
  switch (depth) {
    case CV_8U: return "8-bit";
    case CV_8S: return "8-bit signed";
    case CV_16U: return "16-bit";
    case CV_16S: return "16-bit signed";
    case CV_32S: return "32-bit integer";
    case CV_32F: return "32-bit float";
    case CV_64F: return "64-bit float";
    default: return "unknown depth";
  }
}

}  // namespace

Result<cv::Mat> depthToMillimetres(const cv::Mat& d, double scale, const std::string& name, int width, int height) {
  if (d.empty()) return fail(Status::BadArgument, name + ": empty image");
  if (d.depth() != CV_16U || d.channels() != 1)
    return fail(Status::BadArgument, fmt::format("{}: a depth image must be 16-bit single-channel; this one is {}, {} channel{}", name,
                                                 depthName(d.depth()), d.channels(), d.channels() == 1 ? "" : "s"));
  if (width > 0 && height > 0 && (d.cols != width || d.rows != height))
    return fail(Status::BadArgument, fmt::format("{}: {}x{} px, but camera.yaml says {}x{}", name, d.cols, d.rows, width, height));
  if (cv::countNonZero(d) == 0) return fail(Status::BadArgument, name + ": no valid depth pixel (every value is 0)");
  if (!(scale > 0)) return fail(Status::BadArgument, fmt::format("{}: depth scale {} mm: expected > 0", name, scale));
  cv::Mat mm;
  d.convertTo(mm, CV_32FC1, scale);
  return mm;
}

Result<cv::Mat> readDepthMm(const std::string& path, double scale, int width, int height) {
  const cv::Mat d = cv::imread(path, cv::IMREAD_UNCHANGED);
  if (d.empty()) return fail(Status::BadArgument, path + ": cannot read the image");
  return depthToMillimetres(d, scale, path, width, height);
}

}  // namespace vgr::vision
