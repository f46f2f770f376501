#include "vision/overlay.hpp"

#include <algorithm>
#include <cmath>
#include <numbers>

#include <fmt/core.h>
#include <opencv2/imgproc.hpp>

namespace vgr::vision {

namespace {

const cv::Scalar kRoiColour(0, 220, 255);     // yellow
const cv::Scalar kPartColour(60, 220, 60);    // green
const cv::Scalar kGraspColour(255, 0, 255);   // magenta
const cv::Scalar kRimColour(255, 255, 255);
const cv::Scalar kTextColour(255, 255, 255);
const cv::Scalar kOkColour(90, 230, 90);
const cv::Scalar kFailColour(80, 80, 255);

// Image px (pixel centres at integers) -> output px, and as a cv::Point with 4 fractional
// bits (cv::line's `shift`), so sub-pixel positions are drawn where they are.
constexpr int kShift = 4;
cv::Point fixed(double x, double y) {
  return {static_cast<int>(std::lround(x * (1 << kShift))), static_cast<int>(std::lround(y * (1 << kShift)))};
}

// (dx, dy) turned by `deg` counter-clockwise as displayed (y down).
cv::Point2d turn(double dx, double dy, double deg) {
  const double a = deg * std::numbers::pi / 180.0;
  return {dx * std::cos(a) + dy * std::sin(a), -dx * std::sin(a) + dy * std::cos(a)};
}

void text(cv::Mat& img, const std::string& s, cv::Point at, double fontScale, const cv::Scalar& colour) {
  const int thick = std::max(1, static_cast<int>(std::lround(fontScale * 2)));
  // A dark outline first, so the text reads on bright and dark parts alike.
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, fontScale, cv::Scalar(0, 0, 0), thick + 2, cv::LINE_AA);
  cv::putText(img, s, at, cv::FONT_HERSHEY_SIMPLEX, fontScale, colour, thick, cv::LINE_AA);
}

}  // namespace

std::vector<OverlayPart> overlayParts(const std::vector<Detection>& found) {
  std::vector<OverlayPart> out;
  out.reserve(found.size());
  for (const auto& d : found) out.push_back({d.u, d.v, d.angleDeg, d.score, d.label, d.confidence});
  return out;
}

std::vector<OverlayPart> overlayParts(const std::vector<PartResult>& parts) {
  std::vector<OverlayPart> out;
  out.reserve(parts.size());
  for (const auto& p : parts) out.push_back({p.uPx, p.vPx, p.angleImgDeg, p.score, p.label, p.confidence});
  return out;
}

std::string cycleCaption(std::uint32_t cycleId, int jobId, Status status, std::size_t parts) {
  if (status == Status::Ok) return fmt::format("cycle {}  job {}  OK  {} part{}", cycleId, jobId, parts, parts == 1 ? "" : "s");
  return fmt::format("cycle {}  job {}  {} {}", cycleId, jobId, statusCode(status), statusName(status));
}

double overlayScaleFor(int width, int maxWidth) {
  if (width <= 0 || maxWidth <= 0 || width <= maxWidth) return 1.0;
  return static_cast<double>(maxWidth) / width;
}

cv::Mat drawOverlay(const cv::Mat& gray, const OverlayFrame& frame, double scale) {
  if (!(scale > 0 && scale <= 1)) scale = 1;
  cv::Mat small;
  if (scale < 1)
    cv::resize(gray, small, cv::Size(), scale, scale, cv::INTER_AREA);
  else
    small = gray;
  cv::Mat out;
  if (small.channels() == 1)
    cv::cvtColor(small, out, cv::COLOR_GRAY2BGR);
  else
    out = small.clone();
  // Output px of an image point: (x + 0.5) * scale - 0.5 keeps pixel centres on centres.
  auto px = [scale](double x) { return (x + 0.5) * scale - 0.5; };
  const int line = std::max(1, static_cast<int>(std::lround(out.cols / 640.0)));
  const double font = std::clamp(out.cols / 1600.0, 0.4, 1.2);

  const PixelRect& roi = frame.job.searchRoi;
  if (!roi.empty())
    // On the ROI's boundary pixels (whole pixels: a crisp line).
    cv::rectangle(out, cv::Point(static_cast<int>(std::lround(px(roi.x))), static_cast<int>(std::lround(px(roi.y)))),
                  cv::Point(static_cast<int>(std::lround(px(roi.x + roi.width - 1))),
                            static_cast<int>(std::lround(px(roi.y + roi.height - 1)))),
                  kRoiColour, line, cv::LINE_8);

  int rank = 0;
  for (const auto& p : frame.parts) {
    ++rank;
    const double u = px(p.u), v = px(p.v);
    const OverlayJob& job = frame.job;
    double reach = 30.0;  // output px: axis length without a template
    if (job.templateWidth > 0 && job.templateHeight > 0) {
      const double x0 = -0.5 - job.templateGrasp.u, x1 = job.templateWidth - 0.5 - job.templateGrasp.u;
      const double y0 = -0.5 - job.templateGrasp.v, y1 = job.templateHeight - 0.5 - job.templateGrasp.v;
      const cv::Point2d corners[4] = {{x0, y0}, {x1, y0}, {x1, y1}, {x0, y1}};
      std::vector<cv::Point> poly;
      for (const auto& c : corners) {
        const cv::Point2d t = turn(c.x, c.y, p.angleDeg);
        poly.push_back(fixed(u + t.x * scale, v + t.y * scale));
      }
      cv::polylines(out, poly, true, kPartColour, line, cv::LINE_AA, kShift);
      reach = std::max(reach, 0.35 * std::min(job.templateWidth, job.templateHeight) * scale);
    }
    const cv::Point2d axis = turn(reach, 0, p.angleDeg);
    cv::arrowedLine(out, fixed(u, v), fixed(u + axis.x, v + axis.y), kPartColour, line + 1, cv::LINE_AA, kShift, 0.2);
    cv::circle(out, fixed(u, v), (kGraspRadiusPx + line) << kShift, kRimColour, cv::FILLED, cv::LINE_AA, kShift);
    cv::circle(out, fixed(u, v), kGraspRadiusPx << kShift, kGraspColour, cv::FILLED, cv::LINE_AA, kShift);
    std::string tag = fmt::format("#{} {:.2f}", rank, p.score);
    if (p.label != 0) tag += fmt::format(" L{} {:.2f}", p.label, p.confidence);
    text(out, tag, cv::Point(static_cast<int>(u) + kGraspRadiusPx + 4, static_cast<int>(v) - kGraspRadiusPx - 4), font,
         kTextColour);
  }

  if (!frame.caption.empty()) {
    int base = 0;
    const int thick = std::max(1, static_cast<int>(std::lround(font * 2)));
    const cv::Size sz = cv::getTextSize(frame.caption, cv::FONT_HERSHEY_SIMPLEX, font, thick, &base);
    const int h = sz.height + base + 12;
    cv::rectangle(out, cv::Rect(0, 0, std::min(out.cols, sz.width + 16), std::min(out.rows, h)), cv::Scalar(0, 0, 0), cv::FILLED);
    cv::putText(out, frame.caption, cv::Point(8, sz.height + 6), cv::FONT_HERSHEY_SIMPLEX, font,
                frame.ok ? kOkColour : kFailColour, thick, cv::LINE_AA);
  }
  return out;
}

}  // namespace vgr::vision
