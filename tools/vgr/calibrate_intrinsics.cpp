#include "tools/vgr/calibrate_intrinsics.hpp"

#include <glob.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "vision/calib/intrinsics.hpp"
#include "vision/calib/mapping.hpp"
#include "vision/gray_image.hpp"

namespace vgr::tools {
namespace calib = vision::calib;
namespace fs = std::filesystem;

namespace {

std::string joinNames(const std::vector<std::string>& names) {
  std::string list;
  for (const auto& n : names) list += (list.empty() ? "" : ", ") + n;
  return list;
}

}  // namespace

int runCalibrateIntrinsics(const CalibIntrinsicsOptions& o) {
  if (auto w = checkOutputPath(o.out); !w) return bad(w.error().message);
  auto spec = patternSpec(o.pattern);
  if (!spec) return bad(spec.error().message);
  glob_t g{};
  const int grc = ::glob(o.images.c_str(), 0, nullptr, &g);
  std::vector<std::string> files;
  for (std::size_t i = 0; grc == 0 && i < g.gl_pathc; ++i) files.emplace_back(g.gl_pathv[i]);
  ::globfree(&g);
  if (files.empty()) return bad(fmt::format("--images '{}': no file matches", o.images));
  std::sort(files.begin(), files.end());

  std::vector<calib::ViewDetection> views;
  cv::Size size;
  for (std::size_t i = 0; i < files.size(); ++i) {
    const std::string name = fs::path(files[i]).filename().string();
    auto read = vision::readGray8(files[i]);
    if (!read) return bad(read.error().message);
    const cv::Mat img = *read;
    if (size.width == 0) size = img.size();
    if (img.size() != size)
      return bad(fmt::format("{}: {}x{} px, the first image is {}x{} px (one camera, one size)", files[i], img.cols,
                             img.rows, size.width, size.height));
    views.push_back(calib::detectPattern(img, *spec, name));
    const auto& d = views.back();
    progress(i + 1, files.size(), name,
             d.found ? fmt::format("found {} points{}{}", d.corners.size(),
                                   d.ids.size() && d.ids.size() < static_cast<std::size_t>(spec->cols * spec->rows)
                                       ? fmt::format(" of {} (partial view)", spec->cols * spec->rows)
                                       : "",
                                   d.note.empty() ? "" : "; " + d.note)
                     : "pattern NOT found" + (d.note.empty() ? "" : ": " + d.note));
  }
  std::vector<std::string> notFound;
  for (const auto& v : views)
    if (!v.found) notFound.push_back(v.name);
  if (notFound.size() == views.size())
    return bad(fmt::format("too few views: the {} {}x{} was found in none of the {} images ({}){}", calib::patternKindName(spec->kind),
                           spec->cols, spec->rows, views.size(), joinNames(notFound),
                           spec->kind == calib::PatternKind::Charuco
                               ? fmt::format(": check --dict (now {}), --cols/--rows (inner corners = squares - 1) and "
                                             "--square/--marker",
                                             spec->dictionary)
                               : ""));
  calib::IntrinsicsOptions io;
  io.tangential = !o.noTangential;
  auto r = calib::calibrateIntrinsics(views, *spec, size, io);
  if (!r) return bad(r.error().message);
  const auto& c = r->camera;
  std::printf("per-view reprojection error (px):\n");
  for (const auto& v : c.views)
    if (v.used) std::printf("  %-32s %7.3f   tilt %5.1f deg\n", v.name.c_str(), v.rmsPx, v.tiltDeg);
  for (const auto& v : r->rejectedViews) std::printf("  rejected as outlier, re-solved without: %s\n", v.c_str());
  for (const auto& v : views)
    if (!v.found) std::printf("  pattern not found, not used: %s\n", v.name.c_str());
  std::printf("coverage: %.0f %% of the image, tilt %.1f..%.1f deg\n", r->coverage.imageCoverage * 100,
              r->coverage.minTiltDeg, r->coverage.maxTiltDeg);
  for (const auto& a : r->coverage.advice) std::printf("  more views needed: %s\n", a.c_str());
  std::printf("result: rms %.4f px, fx %.3f fy %.3f cx %.3f cy %.3f, k1 %.5f k2 %.5f p1 %.6f p2 %.6f k3 %.5f, %zu views used\n",
              c.rmsPx, c.fx(), c.fy(), c.cx(), c.cy(), c.dist[0], c.dist[1], c.dist[2], c.dist[3], c.dist[4],
              r->usedViews.size());
  const auto& sd = c.stdDev;
  std::printf("std dev: fx %.3f fy %.3f cx %.3f cy %.3f px, k1 %.5f k2 %.5f p1 %.6f p2 %.6f k3 %.5f\n", sd[0], sd[1], sd[2],
              sd[3], sd[4], sd[5], sd[6], sd[7], sd[8]);
  if (c.tangential)
    std::printf("tangential distortion: p1 %.1f std dev, p2 %.1f std dev from 0%s\n", r->coverage.p1Sigmas,
                r->coverage.p2Sigmas,
                std::max(r->coverage.p1Sigmas, r->coverage.p2Sigmas) < 2
                    ? " (not significant: --no-tangential would pin the principal point down better)"
                    : "");
  else
    std::printf("tangential distortion held at 0 (--no-tangential)\n");
  if (const calib::CellCalibrationLimits limits; c.rmsPx > limits.maxReprojPx)
    return implausible("intrinsics", fmt::format("the plate reprojects at {:.2f} px RMS (vgrd's limit {} px)", c.rmsPx, limits.maxReprojPx),
                       "Hint: check --cols/--rows (inner corners), --pattern, that every image shows the same plate, and "
                       "leave out blurred views");
  if (auto w = calib::writeIntrinsics(o.out, c); !w) return bad(w.error().message);
  std::printf("written: %s\n", o.out.c_str());
  if (o.json) {
    nlohmann::json j{{"rms_px", c.rmsPx}, {"fx", c.fx()}, {"fy", c.fy()}, {"cx", c.cx()}, {"cy", c.cy()},
                     {"dist", {c.dist[0], c.dist[1], c.dist[2], c.dist[3], c.dist[4]}},
                     {"std_dev", {sd[0], sd[1], sd[2], sd[3], sd[4], sd[5], sd[6], sd[7], sd[8]}},
                     {"tangential", c.tangential},
                     {"views_used", r->usedViews.size()}, {"views_total", views.size()},
                     {"rejected", r->rejectedViews}, {"coverage", r->coverage.imageCoverage},
                     {"advice", r->coverage.advice}, {"out", o.out}};
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

CLI::App* CalibrateIntrinsicsCommand::add(CLI::App& parent) {
  auto& calIntr = options_;
  auto* calIntrCmd = parent.add_subcommand("intrinsics", "camera matrix and distortion from plate images");
  calIntrCmd->add_option("--images", calIntr.images, "glob of the plate images, e.g. 'calib/*.png'")->required();
  addPatternOptions(*calIntrCmd, calIntr.pattern);
  calIntrCmd->add_option("--out", calIntr.out, "OpenCV FileStorage YAML to write");
  calIntrCmd->add_flag("--no-tangential", calIntr.noTangential,
                       "hold the tangential distortion p1, p2 at 0 (only for a lens known to have none)");
  calIntrCmd->add_flag("--json", calIntr.json, "end with one JSON line (rms_px, fx, fy, cx, cy, views_used, ...)");
  return calIntrCmd;
}

}  // namespace vgr::tools
