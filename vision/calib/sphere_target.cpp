#include "vision/calib/sphere_target.hpp"

#include <algorithm>
#include <cmath>
#include <cstdint>
#include <filesystem>
#include <functional>
#include <unordered_map>

#include <Eigen/Dense>
#include <fmt/core.h>
#include <opencv2/core/persistence.hpp>

#include "vision/calib/se3.hpp"

namespace vgr::vision::calib {
namespace {

using Eigen::Vector3d;

Vector3d ev(const Vec3& v) { return {v.x, v.y, v.z}; }
Vec3 vv(const Vector3d& v) { return {v.x(), v.y(), v.z()}; }

struct CellKey {
  std::int64_t value;
  bool operator==(const CellKey& o) const { return value == o.value; }
};
struct CellHash {
  std::size_t operator()(const CellKey& k) const { return std::hash<std::int64_t>()(k.value); }
};
CellKey key(int ix, int iy, int iz) {
  constexpr std::int64_t kOff = 1 << 20, kMask = (1 << 21) - 1;
  return {((ix + kOff) & kMask) | (((iy + kOff) & kMask) << 21) | (((iz + kOff) & kMask) << 42)};
}

struct Votes {
  int count = 0;
  Vector3d sum = Vector3d::Zero();
};

// The camera-frame point of pixel (u, v) with depth z.
Vector3d pointAt(const DepthIntrinsics& k, int u, int v, float z) {
  return {(u - k.cx) * z / k.fx, (v - k.cy) * z / k.fy, static_cast<double>(z)};
}

// Depth pixels near a candidate sphere: inside the window around its projection and within
// `band` mm of its surface.
std::vector<Vector3d> gather(const cv::Mat& depth, const DepthIntrinsics& k, const Vector3d& c, double radius, double band) {
  std::vector<Vector3d> pts;
  if (c.z() <= radius) return pts;
  const double u0 = k.fx * c.x() / c.z() + k.cx, v0 = k.fy * c.y() / c.z() + k.cy;
  const double rpx = 1.3 * radius * std::max(k.fx, k.fy) / (c.z() - radius) + 2;
  const int ua = std::max(0, static_cast<int>(std::floor(u0 - rpx))), ub = std::min(depth.cols - 1, static_cast<int>(std::ceil(u0 + rpx)));
  const int va = std::max(0, static_cast<int>(std::floor(v0 - rpx))), vb = std::min(depth.rows - 1, static_cast<int>(std::ceil(v0 + rpx)));
  for (int v = va; v <= vb; ++v) {
    const float* row = depth.ptr<float>(v);
    for (int u = ua; u <= ub; ++u) {
      if (!(row[u] > 0)) continue;
      const Vector3d p = pointAt(k, u, v, row[u]);
      if (std::abs((p - c).norm() - radius) < band) pts.push_back(p);
    }
  }
  return pts;
}

// Gauss-Newton on r_i = |p_i - c| - R: the centre with the radius fixed (3 unknowns) or free
// (4). Returns the radial RMS.
double fitSphere(const std::vector<Vector3d>& pts, Vector3d& c, double& radius, bool freeRadius) {
  if (pts.size() < 8) return 1e9;
  for (int it = 0; it < 20; ++it) {
    Eigen::Matrix4d jtj = Eigen::Matrix4d::Zero();
    Eigen::Vector4d jtr = Eigen::Vector4d::Zero();
    for (const auto& p : pts) {
      const Vector3d d = p - c;
      const double n = d.norm();
      if (n < 1e-9) continue;
      Eigen::Vector4d j;
      j.head<3>() = -d / n;
      j(3) = -1.0;
      const double r = n - radius;
      jtj += j * j.transpose();
      jtr += j * r;
    }
    Eigen::Vector4d delta = Eigen::Vector4d::Zero();
    if (freeRadius) {
      delta = -jtj.ldlt().solve(jtr);
    } else {
      delta.head<3>() = -jtj.topLeftCorner<3, 3>().ldlt().solve(jtr.head<3>());
    }
    if (!delta.allFinite()) return 1e9;
    c += delta.head<3>();
    radius += delta(3);
    if (delta.norm() < 1e-7) break;
  }
  double s = 0;
  for (const auto& p : pts) s += std::pow((p - c).norm() - radius, 2);
  return std::sqrt(s / static_cast<double>(pts.size()));
}

}  // namespace

Result<void> validateSphereTarget(const SphereTarget& t) {
  if (!(t.radiusMm > 0 && t.radiusMm <= 500))
    return fail(Status::BadArgument, fmt::format("sphere target: radius {} mm, expected (0, 500]", t.radiusMm));
  if (t.centres.size() < 4)
    return fail(Status::BadArgument, fmt::format("sphere target: {} spheres, at least 4 are needed", t.centres.size()));
  for (std::size_t i = 0; i < t.centres.size(); ++i)
    for (std::size_t j = i + 1; j < t.centres.size(); ++j) {
      const double d = (ev(t.centres[i]) - ev(t.centres[j])).norm();
      if (d < 2.5 * t.radiusMm)
        return fail(Status::BadArgument, fmt::format("sphere target: spheres {} and {} are {:.1f} mm apart, at least 2.5 radii "
                                                     "({:.1f} mm) are needed",
                                                     i, j, d, 2.5 * t.radiusMm));
    }
  Vector3d a = ev(t.centres[0]), b = ev(t.centres[1]);
  double spread = 0;
  for (const auto& c : t.centres) spread = std::max(spread, (ev(c) - a).cross((b - a).normalized()).norm());
  if (spread < t.radiusMm) return fail(Status::BadArgument, "sphere target: the spheres lie on one line");
  return {};
}

Result<void> writeSphereTarget(const std::string& path, const SphereTarget& t) {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot open for writing", path));
    cv::Mat c(static_cast<int>(t.centres.size()), 3, CV_64F);
    for (std::size_t i = 0; i < t.centres.size(); ++i) {
      c.at<double>(static_cast<int>(i), 0) = t.centres[i].x;
      c.at<double>(static_cast<int>(i), 1) = t.centres[i].y;
      c.at<double>(static_cast<int>(i), 2) = t.centres[i].z;
    }
    fs << "calibration_kind" << "sphere_target" << "radius_mm" << t.radiusMm << "centres_mm" << c;
  } catch (const cv::Exception& e) {
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  return {};
}

Result<SphereTarget> readSphereTarget(const std::string& path) {
  if (!std::filesystem::exists(path)) return fail(Status::BadArgument, fmt::format("{}: no such target file", path));
  SphereTarget t;
  try {
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot open the target file", path));
    if (static_cast<std::string>(fs["calibration_kind"]) != "sphere_target")
      return fail(Status::BadArgument, fmt::format("{}: key 'calibration_kind' must be sphere_target", path));
    if (fs["radius_mm"].empty() || fs["centres_mm"].empty())
      return fail(Status::BadArgument, fmt::format("{}: keys 'radius_mm' and 'centres_mm' are required", path));
    t.radiusMm = static_cast<double>(fs["radius_mm"]);
    cv::Mat c;
    fs["centres_mm"] >> c;
    if (c.cols != 3 || c.rows < 1) return fail(Status::BadArgument, fmt::format("{}: key 'centres_mm': expected n x 3", path));
    c.convertTo(c, CV_64F);
    for (int i = 0; i < c.rows; ++i) t.centres.push_back({c.at<double>(i, 0), c.at<double>(i, 1), c.at<double>(i, 2)});
  } catch (const cv::Exception& e) {
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  if (auto ok = validateSphereTarget(t); !ok) return fail(Status::BadArgument, path + ": " + ok.error().message);
  return t;
}

std::vector<SphereDetection> findSpheres(const cv::Mat& depth, const DepthIntrinsics& k, double radius,
                                         const SphereFindOptions& o) {
  std::vector<SphereDetection> out;
  if (depth.empty() || depth.type() != CV_32FC1 || !(radius > 0) || !(k.fx > 0) || !(k.fy > 0)) return out;
  // 1. Votes: each pixel with a normal proposes a centre one radius behind its surface.
  const double cell = std::max(1.0, radius / 4);
  const int s = std::max(1, o.normalStepPx);
  const double jump = 0.5 * radius;  // depth steps larger than this between neighbours: an edge, no normal
  std::unordered_map<CellKey, Votes, CellHash> votes;
  votes.reserve(static_cast<std::size_t>(depth.total() / 4));
  for (int v = s; v < depth.rows - s; ++v) {
    const float* row = depth.ptr<float>(v);
    const float* up = depth.ptr<float>(v - s);
    const float* down = depth.ptr<float>(v + s);
    for (int u = s; u < depth.cols - s; ++u) {
      const float z = row[u], zl = row[u - s], zr = row[u + s], zu = up[u], zd = down[u];
      if (!(z > 0 && zl > 0 && zr > 0 && zu > 0 && zd > 0)) continue;
      if (std::abs(zr - zl) > jump || std::abs(zd - zu) > jump) continue;
      const Vector3d p = pointAt(k, u, v, z);
      const Vector3d dx = pointAt(k, u + s, v, zr) - pointAt(k, u - s, v, zl);
      const Vector3d dy = pointAt(k, u, v + s, zd) - pointAt(k, u, v - s, zu);
      Vector3d n = dx.cross(dy);
      const double len = n.norm();
      if (len < 1e-12) continue;
      n /= len;
      if (n.dot(p) > 0) n = -n;  // toward the camera: outward on a sphere seen from outside
      const Vector3d c = p - radius * n;
      Votes& cellVotes = votes[key(static_cast<int>(std::floor(c.x() / cell)), static_cast<int>(std::floor(c.y() / cell)),
                                   static_cast<int>(std::floor(c.z() / cell)))];
      cellVotes.count++;
      cellVotes.sum += c;
    }
  }
  // 2. Candidates: cells by the votes of their 3 x 3 x 3 neighbourhood, strongest first.
  struct Candidate {
    int score;
    Vector3d centre;
  };
  std::vector<Candidate> cands;
  for (const auto& [kk, vt] : votes) {
    if (vt.count < 3) continue;
    const auto ix = static_cast<int>((kk.value & ((1 << 21) - 1)) - (1 << 20));
    const auto iy = static_cast<int>(((kk.value >> 21) & ((1 << 21) - 1)) - (1 << 20));
    const auto iz = static_cast<int>(((kk.value >> 42) & ((1 << 21) - 1)) - (1 << 20));
    int score = 0;
    Vector3d sum = Vector3d::Zero();
    for (int dx = -1; dx <= 1; ++dx)
      for (int dy = -1; dy <= 1; ++dy)
        for (int dz = -1; dz <= 1; ++dz) {
          const auto it = votes.find(key(ix + dx, iy + dy, iz + dz));
          if (it == votes.end()) continue;
          score += it->second.count;
          sum += it->second.sum;
        }
    if (score <= 0) continue;
    const Vector3d c = sum / score;
    if (c.z() <= radius) continue;
    // A whole visible hemisphere covers about pi (R f / z)^2 pixels.
    const double hemisphere = M_PI * std::pow(radius * std::max(k.fx, k.fy) / c.z(), 2);
    if (score < 0.5 * o.minCoverage * hemisphere) continue;
    cands.push_back({score, c});
  }
  std::sort(cands.begin(), cands.end(), [](const Candidate& a, const Candidate& b) { return a.score > b.score; });
  // 3. Refinement and acceptance, non-maximum suppressed within one radius.
  std::vector<Vector3d> tried;
  for (const auto& cand : cands) {
    if (tried.size() >= 64) break;
    bool near = false;
    for (const auto& t : tried) near = near || (t - cand.centre).norm() < radius;
    if (near) continue;
    tried.push_back(cand.centre);
    Vector3d c = cand.centre;
    double r = radius, rms = 1e9;
    std::vector<Vector3d> pts;
    // Capture with a wide band, then tighten to 2 mm and 1.5 mm (5 sigma of a 0.3 mm sensor).
    for (const double band : {0.25 * radius, 2.0, 1.5}) {
      pts = gather(depth, k, c, radius, band);
      r = radius;
      rms = fitSphere(pts, c, r, false);
    }
    const double hemisphere = M_PI * std::pow(radius * std::max(k.fx, k.fy) / c.z(), 2);
    if (rms > o.maxRmsMm || static_cast<double>(pts.size()) < o.minCoverage * hemisphere) continue;
    Vector3d cf = c;
    double rf = radius;
    fitSphere(pts, cf, rf, true);
    if (!(std::abs(rf - radius) <= o.radiusTolerance * radius)) continue;
    bool duplicate = false;
    for (const auto& d : out) duplicate = duplicate || (ev(d.centre) - c).norm() < radius;
    if (duplicate) continue;
    out.push_back({vv(c), rms, rf, static_cast<int>(pts.size())});
  }
  return out;
}

Pose rigidFit(const std::vector<Vec3>& from, const std::vector<Vec3>& to) {
  const std::size_t n = std::min(from.size(), to.size());
  Vector3d ca = Vector3d::Zero(), cb = Vector3d::Zero();
  for (std::size_t i = 0; i < n; ++i) ca += ev(from[i]), cb += ev(to[i]);
  ca /= static_cast<double>(n);
  cb /= static_cast<double>(n);
  Eigen::Matrix3d h = Eigen::Matrix3d::Zero();
  for (std::size_t i = 0; i < n; ++i) h += (ev(from[i]) - ca) * (ev(to[i]) - cb).transpose();
  Eigen::JacobiSVD<Eigen::Matrix3d> svd(h, Eigen::ComputeFullU | Eigen::ComputeFullV);
  Eigen::Matrix3d d = Eigen::Matrix3d::Identity();
  d(2, 2) = (svd.matrixV() * svd.matrixU().transpose()).determinant() < 0 ? -1.0 : 1.0;
  se3::Iso t = se3::Iso::Identity();
  t.linear() = svd.matrixV() * d * svd.matrixU().transpose();
  t.translation() = cb - t.linear() * ca;
  return se3::toPose(t);
}

Result<TargetView> matchSphereTarget(const std::vector<SphereDetection>& found, const SphereTarget& target, double maxRmsMm) {
  const std::size_t kMaxDetections = 8;
  std::vector<Vec3> pts;
  for (std::size_t i = 0; i < found.size() && i < kMaxDetections; ++i) pts.push_back(found[i].centre);
  const std::size_t n = pts.size(), m = target.centres.size();
  if (n < 4) return fail(Status::BadArgument, fmt::format("{} sphere(s) found, at least 4 are needed", n));
  // Every injective partial labelling with at least 4 labelled detections (-1 = outlier).
  struct Fit {
    std::size_t count = 0;
    double rms = 1e18;
    std::vector<int> label;
  };
  Fit best, second;
  std::vector<int> label(n, -1);
  std::vector<bool> used(m, false);
  auto evaluate = [&] {
    std::vector<Vec3> a, b;
    for (std::size_t i = 0; i < n; ++i)
      if (label[i] >= 0) a.push_back(target.centres[static_cast<std::size_t>(label[i])]), b.push_back(pts[i]);
    if (a.size() < 4) return;
    const se3::Iso t = se3::toIso(rigidFit(a, b));
    double s = 0;
    for (std::size_t i = 0; i < a.size(); ++i) s += (t * ev(a[i]) - ev(b[i])).squaredNorm();
    const double rms = std::sqrt(s / static_cast<double>(a.size()));
    if (rms > maxRmsMm) return;
    const bool better = a.size() > best.count || (a.size() == best.count && rms < best.rms);
    if (better) {
      if (best.count == a.size()) second = best;
      best = {a.size(), rms, label};
    } else if (a.size() == best.count && rms < second.rms) {
      second = {a.size(), rms, label};
    }
  };
  std::function<void(std::size_t)> assign = [&](std::size_t i) {
    if (i == n) {
      evaluate();
      return;
    }
    label[i] = -1;
    assign(i + 1);
    for (std::size_t j = 0; j < m; ++j) {
      if (used[j]) continue;
      used[j] = true;
      label[i] = static_cast<int>(j);
      assign(i + 1);
      used[j] = false;
    }
    label[i] = -1;
  };
  assign(0);
  if (best.count == 0)
    return fail(Status::BadArgument, fmt::format("{} spheres found, but no 4 of them fit the target within {:.1f} mm", n, maxRmsMm));
  if (second.count == best.count && second.rms < 3 * best.rms + 0.5)
    return fail(Status::BadArgument, fmt::format("the spheres fit the target in two ways ({:.2f} mm and {:.2f} mm RMS): "
                                                 "ambiguous view",
                                                 best.rms, second.rms));
  TargetView v;
  std::vector<Vec3> a;
  for (std::size_t i = 0; i < n; ++i)
    if (best.label[i] >= 0) {
      v.ids.push_back(best.label[i]);
      v.points.push_back(pts[i]);
      a.push_back(target.centres[static_cast<std::size_t>(best.label[i])]);
    }
  v.camFromTarget = rigidFit(a, v.points);
  v.fitRmsMm = best.rms;
  return v;
}

}  // namespace vgr::vision::calib
