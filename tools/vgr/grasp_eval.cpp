#include "tools/vgr/grasp_eval.hpp"

#include <algorithm>
#include <chrono>
#include <memory>
#include <numeric>

#include <nlohmann/json.hpp>

#include "tools/vgr/grasp_dataset.hpp"

namespace vgr::tools {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}
double mean(const std::vector<double>& v) { return v.empty() ? 0 : std::accumulate(v.begin(), v.end(), 0.0) / double(v.size()); }
double maxOf(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }

}  // namespace

Result<GraspEvalReport> evaluateGrasps(const GraspEvalOptions& o) {
  auto set = loadGraspDataset(o.datasetFolder);
  if (!set) return std::unexpected(set.error());
  if (o.detectors.empty()) return fail(Status::BadArgument, "vgr eval --grasp: no detector to run");
  std::vector<std::unique_ptr<vision::grasp::GraspDetector>> dets;
  GraspEvalReport rep;
  rep.dataset = o.datasetFolder;
  for (const auto& name : o.detectors) {
    auto opt = o.detector;
    opt.detector = name;
    auto d = vision::grasp::makeGraspDetector(opt);
    if (!d) return std::unexpected(d.error());
    dets.push_back(std::move(*d));
    rep.detectors.push_back({});
    rep.detectors.back().detector = name;
  }
  const std::size_t n = o.limit > 0 ? std::min(set->images.size(), static_cast<std::size_t>(o.limit)) : set->images.size();
  for (std::size_t i = 0; i < n; ++i) {
    const auto& img = set->images[i];
    auto frame = loadGraspFrame(*set, img);
    if (!frame) return std::unexpected(frame.error());
    const auto truth = truthRects(*set, img);
    ++rep.images;
    rep.graspable += !truth.empty();
    for (std::size_t k = 0; k < dets.size(); ++k) {
      auto& r = rep.detectors[k];
      const auto t0 = std::chrono::steady_clock::now();
      auto grasps = dets[k]->detect(*frame);
      r.timeMs.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      if (!grasps) return std::unexpected(grasps.error());
      if (truth.empty()) {
        r.falsePositives += !grasps->empty();
        continue;
      }
      ++r.graspable;
      if (grasps->empty()) continue;
      ++r.found;
      const auto& g = grasps->front();
      const auto s = vision::grasp::scoreGrasp({g.u, g.v, g.angleDeg, g.widthPx, g.jawPx}, truth, o.metric);
      if (!s.rectSuccess) continue;
      ++r.rectSuccesses;
      r.posErrMm.push_back(s.posErrMm);
      r.angErrDeg.push_back(s.angleErrDeg);
      r.posSuccesses += s.posErrMm <= o.posTolMm;
    }
  }
  return rep;
}

std::string graspEvalJson(const GraspEvalReport& rep, const GraspEvalOptions& o) {
  nlohmann::ordered_json j;
  j["dataset"] = rep.dataset;
  j["images"] = rep.images;
  j["graspable"] = rep.graspable;
  j["metric"] = {{"min_iou", o.metric.minIou}, {"max_angle_deg", o.metric.maxAngleDeg}, {"pos_tol_mm", o.posTolMm}};
  for (const auto& r : rep.detectors) {
    j[r.detector] = {{"rect_success_rate", r.rectSuccessRate()},
                     {"pos_success_rate", r.posSuccessRate()},
                     {"graspable", r.graspable},
                     {"found", r.found},
                     {"rect_successes", r.rectSuccesses},
                     {"pos_successes", r.posSuccesses},
                     {"false_positives", r.falsePositives},
                     {"pos_err_mm_mean", mean(r.posErrMm)},
                     {"pos_err_mm_median", median(r.posErrMm)},
                     {"pos_err_mm_max", maxOf(r.posErrMm)},
                     {"ang_err_deg_mean", mean(r.angErrDeg)},
                     {"time_ms_median", median(r.timeMs)}};
  }
  return j.dump();
}

}  // namespace vgr::tools
