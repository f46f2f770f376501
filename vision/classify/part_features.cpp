#include "vision/classify/part_features.hpp"

#include <algorithm>
#include <cmath>

#include <opencv2/core.hpp>
#include <opencv2/imgproc.hpp>

namespace vgr::vision::classify {
namespace {

// Paper 002 eq. 1 maps a Hu moment to m = sign(h) * log|h|. For symmetric parts h3..h7 are
// ~0 and their sign is noise, so eq. 1 would jump between about -20 and +20: we use the
// continuous "symlog" sign(h) * log10(1 + |h| / 1e-9), equal to eq. 1 up to a constant
// wherever |h| >> 1e-9 and 0 for a vanishing moment.
float signedLog(double h) {
  return static_cast<float>((h < 0 ? -1.0 : 1.0) * std::log10(1 + std::abs(h) / 1e-9));
}

// Features of one outer contour with its holes (contours[outer], children via hierarchy).
FeatureVector contourFeatures(const std::vector<std::vector<cv::Point>>& contours, const std::vector<cv::Vec4i>& hierarchy,
                              int outer, const cv::Moments& m) {
  FeatureVector f{};
  double hu[7];
  cv::HuMoments(m, hu);
  for (int i = 0; i < 7; ++i) f[i] = signedLog(hu[i]);
  const double area = std::max(m.m00, 1.0);
  // The pixel contour's stair steps make arcLength depend on the rotation (+8 % for an edge
  // at 45 degrees, measured); the perimeter of the contour simplified to 1 px does not.
  std::vector<cv::Point> simple;
  cv::approxPolyDP(contours[outer], simple, 1.0, true);
  const double perimeter = std::max(cv::arcLength(simple, true), 1.0);
  f[7] = static_cast<float>(std::log10(area));
  f[8] = static_cast<float>(std::log10(perimeter));
  f[9] = static_cast<float>(4 * M_PI * area / (perimeter * perimeter));
  const cv::RotatedRect box = cv::minAreaRect(contours[outer]);
  const double lo = std::min(box.size.width, box.size.height), hi = std::max(box.size.width, box.size.height);
  f[10] = static_cast<float>(hi > 0 ? lo / hi : 0);
  std::vector<cv::Point> hull;
  cv::convexHull(contours[outer], hull);
  const double hullArea = cv::contourArea(hull);
  int holes = 0;
  double holeArea = 0;
  for (int c = hierarchy[outer][2]; c >= 0; c = hierarchy[c][0]) {
    const double a = cv::contourArea(contours[c]);
    if (a < kMinHoleAreaPx) continue;
    ++holes;
    holeArea += a;
  }
  f[11] = static_cast<float>(hullArea > 0 ? std::min(1.0, (area + holeArea) / hullArea) : 0);
  f[12] = static_cast<float>(holes);
  f[13] = static_cast<float>(holeArea / (area + holeArea));
  return f;
}

}  // namespace

const std::array<const char*, kFeatureCount>& featureNames() {
  static const std::array<const char*, kFeatureCount> names = {
      "hu1", "hu2", "hu3", "hu4", "hu5", "hu6", "hu7", "log_area", "log_perimeter", "compactness",
      "elongation", "solidity", "holes", "hole_ratio"};
  return names;
}

Result<FeatureVector> maskFeatures(const cv::Mat& mask) {
  if (mask.empty() || mask.type() != CV_8UC1) return fail(Status::BadArgument, "part features: expected a CV_8UC1 mask");
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::Mat work = mask != 0;
  cv::findContours(work, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
  int best = -1;
  double bestArea = 0;
  for (int i = 0; i < static_cast<int>(contours.size()); ++i) {
    if (hierarchy[i][3] >= 0) continue;
    const double a = cv::contourArea(contours[i]);
    if (a > bestArea) best = i, bestArea = a;
  }
  if (best < 0) return fail(Status::BadArgument, "part features: the mask is empty");
  return contourFeatures(contours, hierarchy, best, cv::moments(mask != 0, true));
}

Result<std::vector<PartBlob>> segmentParts(const cv::Mat& gray, int threshold, double minAreaPx) {
  if (gray.empty() || gray.type() != CV_8UC1) return fail(Status::BadArgument, "part features: expected a CV_8UC1 image");
  cv::Mat bin;
  if (threshold > 0)
    cv::threshold(gray, bin, threshold, 255, cv::THRESH_BINARY);
  else
    cv::threshold(gray, bin, 0, 255, cv::THRESH_BINARY | cv::THRESH_OTSU);
  std::vector<std::vector<cv::Point>> contours;
  std::vector<cv::Vec4i> hierarchy;
  cv::findContours(bin, contours, hierarchy, cv::RETR_CCOMP, cv::CHAIN_APPROX_NONE);
  std::vector<PartBlob> out;
  for (int i = 0; i < static_cast<int>(contours.size()); ++i) {
    if (hierarchy[i][3] >= 0) continue;
    const cv::Rect r = cv::boundingRect(contours[i]);
    if (r.x <= 0 || r.y <= 0 || r.x + r.width >= gray.cols || r.y + r.height >= gray.rows) continue;
    // Moments of the blob with its holes cut out: the filled outer contour minus the filled
    // inner ones, in a mask over the bounding box (paper 002's bitwise-AND crop, Sec. 3).
    cv::Mat mask = cv::Mat::zeros(r.size(), CV_8UC1);
    cv::drawContours(mask, contours, i, cv::Scalar(255), cv::FILLED, cv::LINE_8, hierarchy, 1, -r.tl());
    const cv::Moments m = cv::moments(mask, true);
    if (m.m00 < minAreaPx) continue;
    PartBlob b;
    b.features = contourFeatures(contours, hierarchy, i, m);
    b.areaPx = m.m00;
    b.cx = r.x + m.m10 / m.m00;
    b.cy = r.y + m.m01 / m.m00;
    b.label = static_cast<int>(out.size()) + 1;
    out.push_back(b);
  }
  return out;
}

}  // namespace vgr::vision::classify
