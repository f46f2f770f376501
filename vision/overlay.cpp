#include "vision/overlay.hpp"

#include <algorithm>
#include <cmath>
#include <limits>
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
// A 3D part's axes: x, y, z as red, green, blue (BGR), each on a dark outline.
const cv::Scalar kAxisColours[3] = {cv::Scalar(40, 40, 255), cv::Scalar(40, 230, 40), cv::Scalar(255, 120, 30)};
constexpr int kDepthColourMap = cv::COLORMAP_TURBO;
constexpr int kDepthHistBins = 1024;
constexpr double kDepthTailShare = 0.005;  // cut from each end of the valid z (colourDepth)

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

// The colour map's 256 entries, value 255 = near (dark red) ... 0 = far (dark blue).
const cv::Mat& depthColourTable() {
  static const cv::Mat table = [] {
    cv::Mat ramp(256, 1, CV_8UC1), out;
    for (int i = 0; i < 256; ++i) ramp.at<uchar>(i) = static_cast<uchar>(i);
    cv::applyColorMap(ramp, out, kDepthColourMap);
    return out;
  }();
  return table;
}

// The colour bar at the right edge of `out` (output px): the colours top (near) to bottom
// (far) with their z in mm at both ends and in the middle, on a black box.
void drawDepthBar(cv::Mat& out, const DepthColourRange& r, double font) {
  const int thick = std::max(1, static_cast<int>(std::lround(font * 2)));
  int base = 0;
  const std::string labels[3] = {fmt::format("{:.0f} mm", r.nearMm), fmt::format("{:.0f}", (r.nearMm + r.farMm) / 2),
                                 fmt::format("{:.0f} mm", r.farMm)};
  int labelW = 0, labelH = 0;
  for (const auto& l : labels) {
    const cv::Size sz = cv::getTextSize(l, cv::FONT_HERSHEY_SIMPLEX, font, thick, &base);
    labelW = std::max(labelW, sz.width);
    labelH = std::max(labelH, sz.height);
  }
  const int pad = 4, barW = std::max(10, out.cols / 48);
  const int barH = std::max(32, out.rows / 2), top = (out.rows - barH) / 2;
  const int barX = out.cols - pad - barW, boxX = barX - pad - labelW - pad;
  if (boxX < 0 || top - labelH < 0) return;  // an image too small for a scale: none
  cv::rectangle(out, cv::Rect(boxX, top - labelH / 2 - pad, out.cols - boxX, barH + labelH + 2 * pad), cv::Scalar(0, 0, 0),
                cv::FILLED);
  const cv::Mat& table = depthColourTable();
  for (int y = 0; y < barH; ++y) {
    const int value = 255 - static_cast<int>(std::lround(255.0 * y / (barH - 1)));
    const cv::Vec3b c = table.at<cv::Vec3b>(value);
    cv::line(out, cv::Point(barX, top + y), cv::Point(barX + barW - 1, top + y), cv::Scalar(c[0], c[1], c[2]), 1, cv::LINE_8);
  }
  const int ys[3] = {top, top + barH / 2, top + barH - 1};
  for (int i = 0; i < 3; ++i) {
    const cv::Size sz = cv::getTextSize(labels[i], cv::FONT_HERSHEY_SIMPLEX, font, thick, &base);
    cv::putText(out, labels[i], cv::Point(barX - pad - sz.width, ys[i] + sz.height / 2), cv::FONT_HERSHEY_SIMPLEX, font,
                kTextColour, thick, cv::LINE_AA);
  }
}

}  // namespace

std::optional<DepthColourRange> colourDepth(const cv::Mat& depthMm, cv::Mat& bgr) {
  CV_Assert(depthMm.type() == CV_32FC1);
  bgr.create(depthMm.size(), CV_8UC3);
  bgr.setTo(cv::Scalar::all(0));
  const cv::Mat valid = depthMm > 0;  // NaN compares false: no data
  double lo = 0, hi = 0;
  if (cv::countNonZero(valid) == 0) return std::nullopt;
  cv::minMaxLoc(depthMm, &lo, &hi, nullptr, nullptr, valid);
  DepthColourRange r{lo, hi};
  if (hi - lo < 1.0) {
    r = {(lo + hi) / 2 - 0.5, (lo + hi) / 2 + 0.5};
  } else {
    // The 0.5th and 99.5th percentiles, to a bin (at most (hi - lo) / 1024).
    cv::Mat hist;
    const int channels[] = {0}, bins[] = {kDepthHistBins};
    const float edges[] = {static_cast<float>(lo), std::nextafter(static_cast<float>(hi), std::numeric_limits<float>::max())};
    const float* ranges[] = {edges};
    cv::calcHist(&depthMm, 1, channels, valid, hist, 1, bins, ranges);
    const double total = cv::sum(hist)[0], width = (hi - lo) / kDepthHistBins;
    double seen = 0;
    int first = 0, last = kDepthHistBins - 1;
    for (int i = 0; i < kDepthHistBins; ++i) {
      seen += hist.at<float>(i);
      if (seen > kDepthTailShare * total) {
        first = i;
        break;
      }
    }
    seen = 0;
    for (int i = kDepthHistBins - 1; i >= 0; --i) {
      seen += hist.at<float>(i);
      if (seen > kDepthTailShare * total) {
        last = i;
        break;
      }
    }
    r = {lo + first * width, lo + (last + 1) * width};
    if (r.farMm - r.nearMm < 1.0) r = {(r.nearMm + r.farMm) / 2 - 0.5, (r.nearMm + r.farMm) / 2 + 0.5};
  }
  // z -> 255 (near) .. 0 (far), saturated outside; then the colour map; no data black.
  cv::Mat value;
  const double a = -255.0 / (r.farMm - r.nearMm);
  depthMm.convertTo(value, CV_8U, a, -a * r.farMm);
  cv::applyColorMap(value, bgr, kDepthColourMap);
  bgr.setTo(cv::Scalar::all(0), ~valid);
  return r;
}

cv::Vec3b depthColour(double zMm, const DepthColourRange& range) {
  const double v = 255.0 * (range.farMm - zMm) / (range.farMm - range.nearMm);
  return depthColourTable().at<cv::Vec3b>(static_cast<int>(std::clamp(std::lround(v), 0L, 255L)));
}

OverlayPart overlayPart3d(const Pose& camFromGrasp, const DepthIntrinsics& k, double score, double axisMm) {
  OverlayPart p;
  p.score = score;
  p.axes3d = true;
  auto project = [&k](const Pose& q) {
    return q.z > 0 ? cv::Point2d(k.cx + k.fx * q.x / q.z, k.cy + k.fy * q.y / q.z) : cv::Point2d(-1e6, -1e6);
  };
  const cv::Point2d o = project(camFromGrasp);
  p.u = o.x;
  p.v = o.y;
  for (int i = 0; i < 3; ++i) {
    Pose end;
    (i == 0 ? end.x : i == 1 ? end.y : end.z) = axisMm;
    p.axisEnds[static_cast<std::size_t>(i)] = project(compose(camFromGrasp, end));
  }
  return p;
}

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
    if (p.axes3d) {
      // The grasp frame's axes, each on a dark outline (they cross every colour of a depth
      // picture); the disc goes on top.
      for (int pass = 0; pass < 2; ++pass)
        for (int i = 0; i < 3; ++i) {
          const cv::Point2d e = p.axisEnds[static_cast<std::size_t>(i)];
          if (std::abs(e.x) > 1e5 || std::abs(e.y) > 1e5) continue;
          cv::arrowedLine(out, fixed(u, v), fixed(px(e.x), px(e.y)), pass == 0 ? cv::Scalar(0, 0, 0) : kAxisColours[i],
                          pass == 0 ? line + 3 : line + 1, cv::LINE_AA, kShift, 0.2);
        }
    } else {
      const cv::Point2d axis = turn(reach, 0, p.angleDeg);
      cv::arrowedLine(out, fixed(u, v), fixed(u + axis.x, v + axis.y), kPartColour, line + 1, cv::LINE_AA, kShift, 0.2);
    }
    cv::circle(out, fixed(u, v), (kGraspRadiusPx + line) << kShift, kRimColour, cv::FILLED, cv::LINE_AA, kShift);
    cv::circle(out, fixed(u, v), kGraspRadiusPx << kShift, kGraspColour, cv::FILLED, cv::LINE_AA, kShift);
    std::string tag = fmt::format("#{} {:.2f}", rank, p.score);
    if (p.label != 0) tag += fmt::format(" L{} {:.2f}", p.label, p.confidence);
    text(out, tag, cv::Point(static_cast<int>(u) + kGraspRadiusPx + 4, static_cast<int>(v) - kGraspRadiusPx - 4), font,
         kTextColour);
  }

  if (frame.depthRange) drawDepthBar(out, *frame.depthRange, font);

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
