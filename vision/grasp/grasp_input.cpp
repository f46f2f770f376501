#include "vision/grasp/grasp_input.hpp"

#include <algorithm>
#include <cmath>
#include <limits>

#include <fmt/core.h>
#include <opencv2/imgproc.hpp>

namespace vgr::vision::grasp {

Result<double> netScale(const DepthIntrinsics& camera, const FloorPlane& floor, const std::string& name) {
  const double z = floor.depthAtPrincipalPoint();
  const double raw = z / camera.fx / kNetMmPerPx;
  // Rounded to 1/32: the input size stays the same when the floor moves by a few mm.
  const double s = std::round(raw * 32) / 32;
  if (!std::isfinite(s) || s < 0.125 || s > 1)
    return fail(Status::BadArgument, fmt::format("{}: the floor is {:.0f} mm away at f = {:.0f} px ({:.2f} mm per px): the grasp network's "
                                                 "input at {} mm per px would need a scale of {:.3f}, outside [1/8, 1]",
                                                 name, z, camera.fx, z / camera.fx, kNetMmPerPx, raw));
  return s;
}

NetInput makeNetInput(const cv::Mat& heightMm, double scale) {
  NetInput in;
  in.cols = std::max(1, static_cast<int>(std::lround(heightMm.cols * scale)));
  in.rows = std::max(1, static_cast<int>(std::lround(heightMm.rows * scale)));
  in.scaleX = static_cast<double>(in.cols) / heightMm.cols;
  in.scaleY = static_cast<double>(in.rows) / heightMm.rows;

  // 2. area resize of the valid heights and of the validity mask: their ratio is the mean of
  // the valid pixels each output pixel covers.
  const cv::Mat valid = hasData(heightMm);
  cv::Mat v32, h0;
  valid.convertTo(v32, CV_32FC1, 1.0 / 255);
  heightMm.copyTo(h0);
  h0.setTo(0, ~valid);
  cv::Mat hs, vs;
  cv::resize(h0, hs, cv::Size(in.cols, in.rows), 0, 0, cv::INTER_AREA);
  cv::resize(v32, vs, cv::Size(in.cols, in.rows), 0, 0, cv::INTER_AREA);
  cv::Mat h(in.rows, in.cols, CV_32FC1);
  for (int y = 0; y < in.rows; ++y)
    for (int x = 0; x < in.cols; ++x) {
      const float w = vs.at<float>(y, x);
      h.at<float>(y, x) = w > 1e-3f ? hs.at<float>(y, x) / w : std::numeric_limits<float>::quiet_NaN();
    }

  // 3. holes: the lowest valid neighbour, kFillPasses times; what is left is the floor (0).
  fillHolesLow(h, kFillPasses);
  h.setTo(0, ~hasData(h));

  // 4. normalise; 5. pad to the stride
  cv::Mat n;
  h.convertTo(n, CV_32FC1, 1.0 / kHeightScaleMm);
  n = cv::max(cv::min(n, 2.0), -1.0);
  const int padR = (kNetStride - in.rows % kNetStride) % kNetStride, padC = (kNetStride - in.cols % kNetStride) % kNetStride;
  cv::copyMakeBorder(n, in.tensor, 0, padR, 0, padC, cv::BORDER_REPLICATE);
  return in;
}

std::array<cv::Mat, 4> drawNetTargets(const std::vector<TargetGrasp>& grasps, const NetInput& in) {
  std::array<cv::Mat, 4> maps;
  for (auto& m : maps) m = cv::Mat::zeros(in.tensor.size(), CV_32FC1);
  const double s = (in.scaleX + in.scaleY) / 2;
  for (const auto& g : grasps) {
    const double th = g.angleDeg * M_PI / 180;
    // along = the line of true centres in the image (perpendicular to the closing axis, y down)
    const cv::Point2d along(std::sin(th), std::cos(th));
    const cv::Point2d c(imageToNet(g.u, in.scaleX), imageToNet(g.v, in.scaleY));
    const double pxPerMm = g.pxPerMm * s;
    const double sigma = std::max(kTargetSigmaMm * pxPerMm, 0.75), half = g.stepMm / 2 * pxPerMm;
    const float values[3] = {static_cast<float>(std::cos(2 * th)), static_cast<float>(std::sin(2 * th)),
                             static_cast<float>(g.widthPx * s / kNetWidthScalePx)};
    const int r = static_cast<int>(std::ceil(3 * sigma + half));
    const int x0 = std::max(0, static_cast<int>(std::floor(c.x)) - r), x1 = std::min(in.tensor.cols - 1, static_cast<int>(std::ceil(c.x)) + r);
    const int y0 = std::max(0, static_cast<int>(std::floor(c.y)) - r), y1 = std::min(in.tensor.rows - 1, static_cast<int>(std::ceil(c.y)) + r);
    for (int y = y0; y <= y1; ++y)
      for (int x = x0; x <= x1; ++x) {
        const cv::Point2d d(x - c.x, y - c.y);
        const double t = std::clamp(d.dot(along), -half, half);
        const cv::Point2d off = d - along * t;
        const float q = static_cast<float>(std::exp(-off.dot(off) / (2 * sigma * sigma)));
        if (q < 0.01f || q <= maps[0].at<float>(y, x)) continue;
        maps[0].at<float>(y, x) = q;
        for (int m = 0; m < 3; ++m) maps[static_cast<std::size_t>(m + 1)].at<float>(y, x) = values[m];
      }
  }
  return maps;
}

}  // namespace vgr::vision::grasp
