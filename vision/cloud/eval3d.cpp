#include "vision/cloud/eval3d.hpp"

#include <algorithm>
#include <numeric>

#include "vision/cloud/cloud_math.hpp"

namespace vgr::vision::cloud {
namespace {

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const std::size_t n = v.size();
  return n % 2 ? v[n / 2] : (v[n / 2 - 1] + v[n / 2]) / 2;
}

double mean(const std::vector<double>& v) { return v.empty() ? 0 : std::accumulate(v.begin(), v.end(), 0.0) / static_cast<double>(v.size()); }
double maxOf(const std::vector<double>& v) { return v.empty() ? 0 : *std::max_element(v.begin(), v.end()); }

}  // namespace

double Eval3dSummary::successRate() const {
  const int n = parts + emptyImages;
  return n == 0 ? 0 : static_cast<double>(successes + emptySuccesses) / n;
}

Eval3dAccumulator::Eval3dAccumulator(std::vector<std::array<double, 3>> modelPoints, Eval3dOptions options)
    : model_(std::move(modelPoints)), o_(options) {}

void Eval3dAccumulator::add(const std::vector<Pose>& truth, const Locate3dResult& r, double wallMs, double cpuMs) {
  ++s_.images;
  wall_.push_back(wallMs);
  cpu_.push_back(cpuMs);
  if (r.outcome == Outcome3d::RetryFromNewViewpoint) ++s_.retries;
  if (r.outcome == Outcome3d::NotFound) ++s_.notFound;
  last_.clear();
  if (truth.empty()) {
    ++s_.emptyImages;
    if (r.parts.empty()) ++s_.emptySuccesses;
    s_.falsePositives += static_cast<int>(r.parts.size());
    for (std::size_t f = 0; f < r.parts.size(); ++f) last_.push_back({static_cast<int>(f), -1, 0, 0, 0, false});
    return;
  }
  s_.parts += static_cast<int>(truth.size());
  // Greedy pairing by origin distance, closest first.
  struct Cand {
    double d;
    std::size_t f, t;
  };
  std::vector<Cand> cands;
  std::vector<Eigen::Matrix4d> tf, tt;
  for (const auto& p : r.parts) tf.push_back(toMatrix(p.pose));
  for (const auto& p : truth) tt.push_back(toMatrix(p));
  for (std::size_t f = 0; f < tf.size(); ++f)
    for (std::size_t t = 0; t < tt.size(); ++t) {
      const double d = translationErrorMm(tf[f], tt[t]);
      if (d <= o_.pairTolMm) cands.push_back({d, f, t});
    }
  std::sort(cands.begin(), cands.end(), [](const Cand& a, const Cand& b) { return a.d < b.d; });
  std::vector<bool> usedF(tf.size(), false), usedT(tt.size(), false);
  int successes = 0;
  for (const auto& c : cands) {
    if (usedF[c.f] || usedT[c.t]) continue;
    usedF[c.f] = usedT[c.t] = true;
    Pair p;
    p.found = static_cast<int>(c.f);
    p.truth = static_cast<int>(c.t);
    p.transErrMm = c.d;
    p.rotErrDeg = rotationErrorDeg(tf[c.f], tt[c.t]);
    double add = 0;
    for (const auto& m : model_) {
      const Eigen::Vector4d q(m[0], m[1], m[2], 1);
      add += ((tf[c.f] * q) - (tt[c.t] * q)).head<3>().norm();
    }
    p.addMm = model_.empty() ? 0 : add / static_cast<double>(model_.size());
    p.success = p.transErrMm <= o_.transTolMm && p.rotErrDeg <= o_.rotTolDeg;
    successes += p.success;
    trans_.push_back(p.transErrMm);
    rot_.push_back(p.rotErrDeg);
    add_.push_back(p.addMm);
    ++s_.paired;
    last_.push_back(p);
  }
  for (std::size_t f = 0; f < tf.size(); ++f)
    if (!usedF[f]) last_.push_back({static_cast<int>(f), -1, 0, 0, 0, false});
  for (std::size_t t = 0; t < tt.size(); ++t)
    if (!usedT[t]) last_.push_back({-1, static_cast<int>(t), 0, 0, 0, false});
  s_.successes += successes;
  s_.missed += static_cast<int>(truth.size()) - successes;
  s_.falsePositives += static_cast<int>(r.parts.size()) - successes;
}

Eval3dSummary Eval3dAccumulator::summary() const {
  Eval3dSummary s = s_;
  s.transErrMean = mean(trans_);
  s.transErrMax = maxOf(trans_);
  s.rotErrMean = mean(rot_);
  s.rotErrMax = maxOf(rot_);
  s.addMean = mean(add_);
  s.timeMsMedian = median(wall_);
  s.cpuMsMedian = median(cpu_);
  s.timeMsMax = maxOf(wall_);
  return s;
}

}  // namespace vgr::vision::cloud
