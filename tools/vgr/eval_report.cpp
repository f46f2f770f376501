#include "tools/vgr/eval_report.hpp"

#include "config/csv_line.hpp"

#include <algorithm>
#include <chrono>
#include <cmath>
#include <filesystem>
#include <fstream>
#include <map>
#include <numeric>
#include <sstream>

#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>
#include <opencv2/imgproc.hpp>

#include "config/dataset_file.hpp"
#include "config/job.hpp"
#include "daemon/job_locator.hpp"
#include "vision/calib/plane_model.hpp"
#include "vision/gray_image.hpp"
#include "vision/locate/locator.hpp"
#include "vision/overlay.hpp"

namespace vgr::tools {
namespace {

constexpr double kDegToRad = M_PI / 180.0;



// What a `vgr sim render` dataset tells about its geometry, for paper 001's rates: the camera
// (dataset.yaml), the template's crop offset, the heights of the part's levels and the grasp
// height (template.yaml). Absent for other datasets.
struct DatasetGeometry {
  std::optional<vision::PinholePlaneModel> camera;
  double offsetX = 0, offsetY = 0;
  std::vector<double> heights;
  double graspHeightMm = 0;
  double fx = 0, cameraHeightMm = 0;
};

DatasetGeometry readGeometry(const std::string& folder) {
  DatasetGeometry g;
  const auto ds = config::loadDatasetFile((std::filesystem::path(folder) / "dataset.yaml").string());
  const auto tp = config::loadPartTemplateFile((std::filesystem::path(folder) / "template.yaml").string());
  if (!ds || !tp) return g;  // not a vgr sim render dataset: fall back to the grasp-level similarity
  g.fx = ds->fx;
  g.cameraHeightMm = ds->cameraHeightMm;
  g.camera.emplace(ds->fx, ds->fy, ds->cx, ds->cy, vision::PinholePlaneModel::downLookingCamera(0, 0, g.cameraHeightMm, 0), 0.0);
  g.offsetX = tp->cropOffsetX;
  g.offsetY = tp->cropOffsetY;
  g.graspHeightMm = tp->graspHeightMm;
  for (const auto& r : tp->regions) g.heights.push_back(r.heightMm);
  if (g.heights.empty()) g.heights.push_back(g.graspHeightMm);
  return g;
}

double angleDiff(double a, double b) { return std::abs(std::remainder(a - b, 360.0)); }

// Is a feature match correct? Its template point, on any of the part's levels, carried by
// the truth pose into the image, lands within tol of the matched image point. Without the
// dataset's geometry: the similarity about the grasp point (exact for flat parts).
bool matchIsTrue(const vision::MatchPair& m, const TruthPart& t, const vision::PixelPoint& graspTpl,
                 const DatasetGeometry& g, double tol) {
  if (g.camera && t.hasPose) {
    const double c = std::cos(t.rzDeg * kDegToRad), s = std::sin(t.rzDeg * kDegToRad);
    for (double h : g.heights) {
      const auto q = g.camera->pixelToPlane({m.templatePx.u + g.offsetX, m.templatePx.v + g.offsetY}, h);
      if (!q) continue;
      const auto px = g.camera->project({t.xMm + c * q->x - s * q->y, t.yMm + s * q->x + c * q->y, h});
      if (px && std::hypot(px->u - m.imagePx.u, px->v - m.imagePx.v) <= tol) return true;
    }
    return false;
  }
  const double a = t.angleDeg * kDegToRad;
  const double dx = m.templatePx.u - graspTpl.u, dy = m.templatePx.v - graspTpl.v;
  const double u = t.u + dx * std::cos(a) + dy * std::sin(a);
  const double v = t.v - dx * std::sin(a) + dy * std::cos(a);
  return std::hypot(u - m.imagePx.u, v - m.imagePx.v) <= tol;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : 0.5 * (v[n / 2 - 1] + v[n / 2]);
}

double mean(const std::vector<double>& v) { return v.empty() ? 0 : std::accumulate(v.begin(), v.end(), 0.0) / v.size(); }
double maxOf(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }

}  // namespace

Result<std::vector<TruthImage>> readTruth(const std::string& folder) {
  const std::string path = (std::filesystem::path(folder) / "truth.csv").string();
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open");
  std::string line;
  if (!std::getline(in, line)) return fail(Status::BadArgument, path + ":1: empty file, expected the header image,x_px,y_px,angle_deg");
  const auto header = config::splitCsvLine(line);
  std::map<std::string, std::size_t> col;
  for (std::size_t i = 0; i < header.size(); ++i) col[header[i]] = i;
  for (const char* k : {"image", "x_px", "y_px", "angle_deg"})
    if (!col.count(k)) return fail(Status::BadArgument, fmt::format("{}:1: header lacks the column '{}'", path, k));
  const bool pose = col.count("x_mm") && col.count("y_mm") && col.count("rz_deg");
  std::vector<TruthImage> out;
  std::map<std::string, std::size_t> index;
  int lineNo = 1;
  while (std::getline(in, line)) {
    ++lineNo;
    if (line.empty() || line == "\r") continue;
    const auto f = config::splitCsvLine(line);
    if (f.size() < header.size()) return fail(Status::BadArgument, fmt::format("{}:{}: expected {} columns, got {}", path, lineNo, header.size(), f.size()));
    const std::string& name = f[col["image"]];
    auto it = index.find(name);
    if (it == index.end()) {
      it = index.emplace(name, out.size()).first;
      out.push_back({name, {}});
    }
    if (f[col["x_px"]].empty()) continue;  // an image without a part
    TruthPart p;
    try {
      p.u = std::stod(f[col["x_px"]]);
      p.v = std::stod(f[col["y_px"]]);
      p.angleDeg = std::stod(f[col["angle_deg"]]);
      if (col.count("label")) p.label = f[col["label"]];
      if (pose && !f[col["x_mm"]].empty()) {
        p.xMm = std::stod(f[col["x_mm"]]);
        p.yMm = std::stod(f[col["y_mm"]]);
        p.rzDeg = std::stod(f[col["rz_deg"]]);
        p.hasPose = true;
      }
    } catch (const std::exception&) {
      return fail(Status::BadArgument, fmt::format("{}:{}: expected numbers in x_px, y_px, angle_deg", path, lineNo));
    }
    out[it->second].parts.push_back(p);
  }
  return out;
}

Result<EvalReport> evaluate(const EvalOptions& o) {
  auto job = config::loadJob(o.jobFolder);
  if (!job) return std::unexpected(job.error());
  const std::string method = o.method.empty() ? job->method : o.method;
  auto locator = daemon::makeJobLocator(*job, method);
  if (!locator) return std::unexpected(locator.error());
  auto truth = readTruth(o.datasetFolder);
  if (!truth) return std::unexpected(truth.error());
  if (truth->empty())
    return fail(Status::BadArgument, (std::filesystem::path(o.datasetFolder) / "truth.csv").string() +
                                         ": no images listed: nothing to evaluate");
  const double pairTol = o.pairTolPx > 0 ? o.pairTolPx : o.posTolPx;
  const DatasetGeometry geo = readGeometry(o.datasetFolder);

  vision::OverlayJob overlayJob;
  if (!o.overlaysDir.empty()) {
    std::error_code ec;
    std::filesystem::create_directories(o.overlaysDir, ec);
    if (ec || !std::filesystem::is_directory(o.overlaysDir))
      return fail(Status::BadArgument, o.overlaysDir + ": cannot create the overlays folder" + (ec ? ": " + ec.message() : ""));
    overlayJob = daemon::overlayJobFor(*job);
  }

  EvalReport rep;
  rep.method = method;
  int graspTp = 0, graspN = 0;
  const std::size_t count = o.limit > 0 ? std::min<std::size_t>(o.limit, truth->size()) : truth->size();
  for (std::size_t i = 0; i < count; ++i) {
    const TruthImage& ti = (*truth)[i];
    const std::string path = (std::filesystem::path(o.datasetFolder) / ti.image).string();
    auto read = vision::readGray8(path);
    if (!read) {
      // Reported (EvalReport::unreadable) and left out; the rest are evaluated.
      rep.unreadable.push_back(read.error().message);
      continue;
    }
    const cv::Mat img = *read;
    const auto t0 = std::chrono::steady_clock::now();
    auto out = (*locator)->locate(img);
    rep.timeMs.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
    if (!out) return fail(out.error().code, fmt::format("{}: {}", path, out.error().message));
    const auto& dets = out->parts;
    if (!o.overlaysDir.empty()) {
      // The picture `vgr locate --overlay` draws of this image (one function: vision/overlay.hpp).
      vision::OverlayFrame f;
      f.job = overlayJob;
      f.parts = vision::overlayParts(dets);
      const Status st = dets.empty() ? Status::NoPartFound : Status::Ok;
      f.caption = fmt::format("{}  {}  {} part{}", method, statusName(st), dets.size(), dets.size() == 1 ? "" : "s");
      f.ok = st == Status::Ok;
      const auto dst = std::filesystem::path(o.overlaysDir) / (std::filesystem::path(ti.image).stem().string() + ".png");
      if (!cv::imwrite(dst.string(), vision::drawOverlay(img, f)))
        return fail(Status::BadArgument, dst.string() + ": cannot write the overlay");
    }
    ++rep.images;
    if (ti.parts.empty()) {
      ++rep.emptyImages;
      ++rep.n;
      if (dets.empty()) ++rep.successes, ++rep.countCorrectImages;
      rep.falsePositives += static_cast<int>(dets.size());
      continue;
    }
    // Truth parts and detections paired by nearest grasp point, closest pairs first, and
    // only within the pairing tolerance: a detection farther from every truth part is a
    // false positive, and the part it did not find is missed.
    std::vector<std::tuple<double, std::size_t, std::size_t>> pairs;
    for (std::size_t a = 0; a < ti.parts.size(); ++a)
      for (std::size_t b = 0; b < dets.size(); ++b) {
        const double d = std::hypot(ti.parts[a].u - dets[b].u, ti.parts[a].v - dets[b].v);
        if (d <= pairTol) pairs.emplace_back(d, a, b);
      }
    std::sort(pairs.begin(), pairs.end());
    std::vector<int> truthTo(ti.parts.size(), -1), detTo(dets.size(), -1);
    for (const auto& [d, a, b] : pairs) {
      if (truthTo[a] >= 0 || detTo[b] >= 0) continue;
      truthTo[a] = static_cast<int>(b);
      detTo[b] = static_cast<int>(a);
    }
    const int unpaired = static_cast<int>(std::count(detTo.begin(), detTo.end(), -1));
    rep.falsePositives += unpaired;
    // The count is correct when every part was found and nothing else was.
    if (unpaired == 0 && std::count(truthTo.begin(), truthTo.end(), -1) == 0) ++rep.countCorrectImages;
    for (std::size_t a = 0; a < ti.parts.size(); ++a) {
      ++rep.n;
      ++rep.parts;
      if (truthTo[a] < 0) {
        ++rep.missed;
        ++graspN;
        continue;
      }
      const auto& d = dets[static_cast<std::size_t>(truthTo[a])];
      const double pe = std::hypot(d.u - ti.parts[a].u, d.v - ti.parts[a].v);
      const double ae = angleDiff(d.angleDeg, ti.parts[a].angleDeg);
      rep.posErrPx.push_back(pe);
      rep.angErrDeg.push_back(ae);
      if (pe <= o.posTolPx && ae <= o.angTolDeg) ++rep.successes;
      if (geo.camera) {
        const double mmPerPx = (geo.cameraHeightMm - geo.graspHeightMm) / geo.fx;
        ++graspN;
        if (pe * mmPerPx < o.graspTpMm && ae < o.graspTpDeg) ++graspTp;
      }
      // The matches belong to the best part (dets[0]).
      if (truthTo[a] == 0)
        for (const auto& m : out->matches) {
          ++rep.matchesTotal;
          if (matchIsTrue(m, ti.parts[a], job->taught.grasp, geo, o.matchTolPx)) ++rep.matchesTrue;
        }
    }
  }
  if (rep.images == 0)
    return fail(Status::BadArgument, fmt::format("{}: none of the {} image(s) could be read, e.g. {}", o.datasetFolder,
                                                 rep.unreadable.size(), rep.unreadable.front()));
  if (geo.camera && graspN > 0) rep.graspTpRate = double(graspTp) / graspN;
  return rep;
}

std::string evalJson(const EvalReport& r, const EvalOptions& o) {
  nlohmann::ordered_json j;
  j["method"] = r.method;
  j["n"] = r.n;
  j["images"] = r.images;
  j["parts"] = r.parts;
  j["empty_images"] = r.emptyImages;
  j["success_rate"] = r.successRate();
  j["pos_tol_px"] = o.posTolPx;
  j["ang_tol_deg"] = o.angTolDeg;
  // Errors of matched parts; with none matched there is no figure (null), not a perfect 0.
  const auto figure = [](const std::vector<double>& v, double (*f)(const std::vector<double>&)) -> nlohmann::ordered_json {
    return v.empty() ? nlohmann::ordered_json(nullptr) : nlohmann::ordered_json(f(v));
  };
  j["pos_err_px_mean"] = figure(r.posErrPx, mean);
  j["pos_err_px_max"] = figure(r.posErrPx, maxOf);
  j["ang_err_deg_mean"] = figure(r.angErrDeg, mean);
  j["ang_err_deg_max"] = figure(r.angErrDeg, maxOf);
  j["time_ms_median"] = median(r.timeMs);
  j["time_ms_max"] = maxOf(r.timeMs);
  j["missed"] = r.missed;
  j["false_positives"] = r.falsePositives;
  j["count_correct_rate"] = r.images ? double(r.countCorrectImages) / r.images : 0.0;
  if (r.matchesTotal > 0) {
    j["match_tp_rate"] = double(r.matchesTrue) / r.matchesTotal;
    j["matches"] = r.matchesTotal;
  } else {
    j["match_tp_rate"] = nullptr;  // not a feature method
  }
  if (r.graspTpRate) j["grasp_tp_rate"] = *r.graspTpRate;
  j["pair_tol_px"] = o.pairTolPx > 0 ? o.pairTolPx : o.posTolPx;
  j["unreadable"] = r.unreadable;
  return j.dump();
}

Result<void> plotErrors(const EvalReport& r, const EvalOptions& o, const std::string& path) {
  // Two panels like paper 000, Fig. 7: errors of all matched parts sorted ascending, position
  // (px) left and angle (deg) right, each with its tolerance as a dashed line.
  constexpr int kW = 520, kH = 360, kPad = 50;
  cv::Mat img(kH, 2 * kW, CV_8UC3, cv::Scalar(255, 255, 255));
  auto panel = [&](int x0, std::vector<double> v, double tol, const std::string& title, const std::string& unit) {
    std::sort(v.begin(), v.end());
    const double top = std::max({tol * 2, v.empty() ? 0.0 : v.back() * 1.05, 1e-6});
    const cv::Rect area(x0 + kPad, 30, kW - kPad - 20, kH - 30 - kPad);
    cv::rectangle(img, area, cv::Scalar(0, 0, 0), 1);
    auto yOf = [&](double e) { return area.y + area.height - static_cast<int>(std::min(e, top) / top * area.height); };
    for (int k = 0; k <= 4; ++k) {
      const double e = top * k / 4;
      cv::putText(img, fmt::format("{:.2f}", e), {x0 + 4, yOf(e) + 4}, cv::FONT_HERSHEY_SIMPLEX, 0.35, cv::Scalar(0, 0, 0));
    }
    for (int x = area.x; x < area.x + area.width; x += 8)
      cv::line(img, {x, yOf(tol)}, {std::min(x + 4, area.x + area.width), yOf(tol)}, cv::Scalar(0, 0, 200), 1);
    for (std::size_t i = 1; i < v.size(); ++i) {
      const auto xOf = [&](std::size_t k) { return area.x + static_cast<int>(double(k) / std::max<std::size_t>(1, v.size() - 1) * area.width); };
      cv::line(img, {xOf(i - 1), yOf(v[i - 1])}, {xOf(i), yOf(v[i])}, cv::Scalar(180, 60, 0), 2, cv::LINE_AA);
    }
    cv::putText(img, fmt::format("{} ({}), {}: {} parts", title, unit, r.method, v.size()), {area.x, 20},
                cv::FONT_HERSHEY_SIMPLEX, 0.45, cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
    cv::putText(img, "sample (sorted by error)", {area.x + area.width / 3, kH - 15}, cv::FONT_HERSHEY_SIMPLEX, 0.4,
                cv::Scalar(0, 0, 0), 1, cv::LINE_AA);
  };
  panel(0, r.posErrPx, o.posTolPx, "position error", "px");
  panel(kW, r.angErrDeg, o.angTolDeg, "angle error", "deg");
  if (!cv::imwrite(path, img)) return fail(Status::BadArgument, path + ": cannot write the plot");
  return {};
}

}  // namespace vgr::tools
