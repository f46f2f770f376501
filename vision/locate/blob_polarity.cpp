#include "vision/locate/blob_polarity.hpp"

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

#include "vision/locate/params.hpp"

namespace vgr::vision {

void segment(const cv::Mat& gray, int threshold, BlobSense sense, cv::Mat& binary) {
  const int type = sense == BlobSense::Dark ? cv::THRESH_BINARY_INV : cv::THRESH_BINARY;
  if (threshold > 0)
    cv::threshold(gray, binary, threshold, 255, type);
  else
    cv::threshold(gray, binary, 0, 255, type | cv::THRESH_OTSU);
}

BlobSense templateSense(const cv::Mat& templateGray, int threshold) {
  if (templateGray.empty() || templateGray.rows < 3 || templateGray.cols < 3) return BlobSense::Bright;
  cv::Mat bin;
  segment(templateGray, threshold, BlobSense::Bright, bin);
  const int last = bin.rows - 1, right = bin.cols - 1;
  const int above = cv::countNonZero(bin.row(0)) + cv::countNonZero(bin.row(last)) +
                    cv::countNonZero(bin(cv::Rect(0, 1, 1, bin.rows - 2))) +
                    cv::countNonZero(bin(cv::Rect(right, 1, 1, bin.rows - 2)));
  const int border = 2 * bin.cols + 2 * (bin.rows - 2);
  return 2 * above > border ? BlobSense::Dark : BlobSense::Bright;
}

BlobSense readBlobPolarity(ParamReader& reader, const cv::Mat& templateGray, int threshold) {
  const std::string p = reader.word("polarity", "use", {"use", "ignore_global"});
  if (p == "ignore_global") return BlobSense::Either;
  return templateSense(templateGray, threshold);
}

const char* senseName(BlobSense sense) {
  switch (sense) {
    case BlobSense::Bright: return "bright";
    case BlobSense::Dark: return "dark";
    case BlobSense::Either: return "either";
  }
  return "?";
}

}  // namespace vgr::vision
