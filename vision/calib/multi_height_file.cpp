#include "vision/calib/multi_height_file.hpp"
#include "vision/calib/calib_file_guard.hpp"

#include <exception>
#include <cmath>
#include <filesystem>

#include <fmt/core.h>
#include <opencv2/core.hpp>

namespace vgr::vision::calib {

MultiHeightFit multiHeightFit(const MultiHeightSamples& s) {
  MultiHeightFit f;
  const std::size_t n = s.gridBase.size();
  double sum = 0;
  std::size_t count = 0;
  for (std::size_t i = 0; i < n; ++i) {
    std::vector<PixelPoint> uv;
    for (const auto& plane : s.image) uv.push_back(plane[i]);
    const PrincipalCurve c = fitKSegmentCurve(s.heights, uv, s.maxSegments);
    for (std::size_t k = 0; k < s.heights.size(); ++k) {
      const PixelPoint q = c.at(s.heights[k]);
      const double d = std::hypot(q.u - uv[k].u, q.v - uv[k].v);
      sum += d * d;
      f.maxPx = std::max(f.maxPx, d);
      ++count;
    }
  }
  f.rmsPx = count ? std::sqrt(sum / static_cast<double>(count)) : 0;
  return f;
}

Result<void> writeMultiHeight(const std::string& path, const MultiHeightSamples& s) {
  // Validate by building the map first: a file that would not load is never written.
  auto map = MultiHeightMap::build(s.rows, s.cols, s.gridBase, s.up, s.heights, s.image, s.maxSegments);
  if (!map) return std::unexpected(map.error());
  const MultiHeightFit fit = multiHeightFit(s);
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot write", path));
    fs << "kind" << "multiheight";
    fs << "rows" << s.rows << "cols" << s.cols;
    fs << "image_width" << s.imageSize.width << "image_height" << s.imageSize.height;
    fs << "up" << cv::Vec3d(s.up.x, s.up.y, s.up.z);
    fs << "max_segments" << s.maxSegments;
    fs << "heights_mm" << s.heights;
    std::vector<double> grid;
    for (const auto& p : s.gridBase) grid.insert(grid.end(), {p.x, p.y, p.z});
    fs << "grid_mm" << grid;
    fs << "image_px" << "[";
    for (const auto& plane : s.image) {
      std::vector<double> uv;
      for (const auto& p : plane) uv.insert(uv.end(), {p.u, p.v});
      fs << uv;
    }
    fs << "]";
    fs << "fit_rms_px" << fit.rmsPx << "fit_max_px" << fit.maxPx;
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  return {};
}

Result<MultiHeightCalibration> readMultiHeight(const std::string& path, double maxFitPx) {
  auto bad = [&](const std::string& key, const std::string& what) {
    return fail(Status::NotCalibrated, fmt::format("{}: key '{}': {}", path, key, what));
  };
  if (!std::filesystem::exists(path)) return fail(Status::NotCalibrated, fmt::format("{}: no such multi-height file", path));
  MultiHeightSamples s;
  try {
    requireYamlText(path);
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return fail(Status::NotCalibrated, fmt::format("{}: cannot open multi-height file", path));
    if (static_cast<std::string>(fs["kind"]) != "multiheight") return bad("kind", "expected 'multiheight'");
    for (const char* key : {"rows", "cols", "image_width", "image_height", "up", "heights_mm", "grid_mm", "image_px"})
      if (fs[key].empty()) return bad(key, "required key is missing");
    s.rows = static_cast<int>(fs["rows"]);
    s.cols = static_cast<int>(fs["cols"]);
    s.imageSize = {static_cast<int>(fs["image_width"]), static_cast<int>(fs["image_height"])};
    if (s.imageSize.width <= 0 || s.imageSize.height <= 0) return bad("image_width", "the image size must be positive");
    cv::Vec3d up;
    fs["up"] >> up;
    if (!(cv::norm(up) > 0.5 && cv::norm(up) < 1.5)) return bad("up", "not a unit vector");
    s.up = {up[0], up[1], up[2]};
    if (!fs["max_segments"].empty()) s.maxSegments = static_cast<int>(fs["max_segments"]);
    fs["heights_mm"] >> s.heights;
    std::vector<double> grid;
    fs["grid_mm"] >> grid;
    if (s.rows < 2 || s.cols < 2) return bad("rows", "the grid needs at least 2 x 2 points");
    const std::size_t n = static_cast<std::size_t>(s.rows) * static_cast<std::size_t>(s.cols);
    if (grid.size() != 3 * n) return bad("grid_mm", fmt::format("{} numbers for {} x {} points (x y z each)", grid.size(), s.rows, s.cols));
    for (std::size_t i = 0; i < n; ++i) s.gridBase.push_back({grid[3 * i], grid[3 * i + 1], grid[3 * i + 2]});
    const cv::FileNode planes = fs["image_px"];
    if (!planes.isSeq() || planes.size() != s.heights.size())
      return bad("image_px", fmt::format("expected one list per height ({})", s.heights.size()));
    for (const auto& node : planes) {
      std::vector<double> uv;
      node >> uv;
      if (uv.size() != 2 * n) return bad("image_px", fmt::format("{} numbers in a plane, expected {} (u v per point)", uv.size(), 2 * n));
      std::vector<PixelPoint> plane;
      for (std::size_t i = 0; i < n; ++i) plane.push_back({uv[2 * i], uv[2 * i + 1]});
      s.image.push_back(std::move(plane));
    }
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::NotCalibrated, fmt::format("{}: {}", path, e.what()));
  }
  for (double h : s.heights)
    if (!std::isfinite(h)) return bad("heights_mm", "not a finite number");
  for (const auto& p : s.gridBase)
    if (!std::isfinite(p.x + p.y + p.z)) return bad("grid_mm", "not a finite number");
  for (const auto& plane : s.image)
    for (const auto& p : plane)
      if (!std::isfinite(p.u + p.v)) return bad("image_px", "not a finite number");
  auto map = MultiHeightMap::build(s.rows, s.cols, s.gridBase, s.up, s.heights, s.image, s.maxSegments);
  if (!map) return fail(Status::NotCalibrated, fmt::format("{}: {}", path, map.error().message));
  const MultiHeightFit fit = multiHeightFit(s);
  if (!(fit.rmsPx <= maxFitPx))
    return fail(Status::NotCalibrated, fmt::format("{}: the principal curves fit the samples with {:.3f} px RMS, above the "
                                                   "{:.2f} px limit: recalibrate",
                                                   path, fit.rmsPx, maxFitPx));
  return MultiHeightCalibration{std::move(s), std::move(*map), fit};
}

}  // namespace vgr::vision::calib
