// Point-pair-feature voting (Drost et al. 2010); see ppf.hpp.
#include "vision/cloud/ppf.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Geometry>

namespace vgr::vision::cloud {
namespace {

double angleBetween(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  return std::atan2(a.cross(b).norm(), a.dot(b));
}

// T_g of an oriented point: moves p to the origin and turns n onto +x (Drost eq. 2's frame).
Eigen::Matrix4d localFrame(const Eigen::Vector3d& p, const Eigen::Vector3d& n) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  const Eigen::Matrix3d r = Eigen::Quaterniond::FromTwoVectors(n, Eigen::Vector3d::UnitX()).toRotationMatrix();
  t.topLeftCorner<3, 3>() = r;
  t.topRightCorner<3, 1>() = -r * p;
  return t;
}

// The angle about +x that brings q (in a reference's local frame) into the half-plane z = 0, y > 0.
double alphaOf(const Eigen::Matrix4d& frame, const Eigen::Vector3d& p2) {
  const Eigen::Vector3d q = frame.topLeftCorner<3, 3>() * p2 + frame.topRightCorner<3, 1>();
  return std::atan2(-q.z(), q.y());
}

Eigen::Matrix4d rotX(double a) {
  Eigen::Matrix4d t = Eigen::Matrix4d::Identity();
  t.topLeftCorner<3, 3>() = Eigen::AngleAxisd(a, Eigen::Vector3d::UnitX()).toRotationMatrix();
  return t;
}

}  // namespace

PpfModel::PpfModel(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals, double distStepMm, double angleStepDeg,
                   int alphaBins, double maxNormalAngleDeg, double maxBucketShare)
    : points_(std::move(points)), normals_(std::move(normals)), distStep_(distStepMm), angleStep_(angleStepDeg * M_PI / 180),
      maxDist_(0), cosMaxNormal_(std::cos(maxNormalAngleDeg * M_PI / 180)), alphaBins_(alphaBins),
      maxBucket_(static_cast<std::size_t>(maxBucketShare * static_cast<double>(points_.size()))) {
  for (const auto& a : points_)
    for (const auto& b : points_) maxDist_ = std::max(maxDist_, (a - b).norm());
  for (std::size_t i = 0; i < points_.size(); ++i) frames_.push_back(localFrame(points_[i], normals_[i]));
  std::vector<Entry> entries;
  for (std::size_t i = 0; i < points_.size(); ++i)
    for (std::size_t j = 0; j < points_.size(); ++j) {
      std::uint32_t k = 0;
      if (i == j || !key(points_[i], normals_[i], points_[j], normals_[j], k)) continue;
      entries.push_back({k, static_cast<std::uint32_t>(i), static_cast<float>(alphaOf(frames_[i], points_[j]))});
    }
  std::sort(entries.begin(), entries.end(), [](const Entry& a, const Entry& b) { return a.key < b.key; });
  // Keys shared by more model pairs than the model has points (coplanar pairs of its large
  // faces: 20-30 % of all pairs in a few keys) are dropped: they fix 3 of 6 degrees of
  // freedom, cost most of the voting time and make flat clutter vote as loud as the part.
  for (std::size_t i = 0; i < entries.size();) {
    std::size_t j = i;
    while (j < entries.size() && entries[j].key == entries[i].key) ++j;
    if (j - i <= maxBucket_) {
      keys_.push_back(entries[i].key);
      first_.push_back(static_cast<std::uint32_t>(votes_.size()));
      for (std::size_t e = i; e < j; ++e)
        votes_.push_back({entries[e].point * static_cast<std::uint32_t>(alphaBins_), entries[e].alpha});
    }
    i = j;
  }
  first_.push_back(static_cast<std::uint32_t>(votes_.size()));
}

bool PpfModel::key(const Eigen::Vector3d& p1, const Eigen::Vector3d& n1, const Eigen::Vector3d& p2, const Eigen::Vector3d& n2,
                   std::uint32_t& out) const {
  const Eigen::Vector3d d = p2 - p1;
  const double len = d.norm();
  if (len < distStep_ || len > maxDist_ + distStep_ || n1.dot(n2) < cosMaxNormal_) return false;
  // F = (|d|, angle(n1, d), angle(n2, d), angle(n1, n2)) quantised (Drost eq. 1)
  const auto dq = static_cast<std::uint32_t>(len / distStep_);
  const auto a1 = static_cast<std::uint32_t>(angleBetween(n1, d) / angleStep_);
  const auto a2 = static_cast<std::uint32_t>(angleBetween(n2, d) / angleStep_);
  const auto a3 = static_cast<std::uint32_t>(angleBetween(n1, n2) / angleStep_);
  out = (((dq * 64u) + a1) * 64u + a2) * 64u + a3;
  return true;
}

std::vector<PpfModel::Vote> PpfModel::match(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals,
                                            int refStep) const {
  std::vector<Vote> out;
  if (points.size() < 2 || votes_.empty()) return out;
  const std::size_t cells = points_.size() * static_cast<std::size_t>(alphaBins_);
  std::vector<std::uint16_t> acc(cells);
  const double binWidth = 2 * M_PI / alphaBins_;
  for (std::size_t r = 0; r < points.size(); r += static_cast<std::size_t>(std::max(1, refStep))) {
    // (a reference's pairs: with every other cluster point)
    std::fill(acc.begin(), acc.end(), 0);
    const Eigen::Matrix4d frame = localFrame(points[r], normals[r]);
    for (std::size_t j = 0; j < points.size(); ++j) {
      std::uint32_t k = 0;
      if (j == r || !key(points[r], normals[r], points[j], normals[j], k)) continue;
      const auto found = std::lower_bound(keys_.begin(), keys_.end(), k);
      if (found == keys_.end() || *found != k) continue;
      const double alphaS = alphaOf(frame, points[j]);
      const auto at = static_cast<std::size_t>(found - keys_.begin());
      const Slot* const end = votes_.data() + first_[at + 1];
      for (const Slot* e = votes_.data() + first_[at]; e != end; ++e) {
        // Drost eq. 3: sceneFromModel = T_s^-1 R_x(alpha_m - alpha_s) T_m. Both alphas lie in
        // [-pi, pi], so the difference wraps into [0, 2 pi) by one addition or subtraction.
        double a = static_cast<double>(e->alpha) - alphaS;
        if (a < 0) a += 2 * M_PI;
        else if (a >= 2 * M_PI) a -= 2 * M_PI;
        const auto bin = std::min(alphaBins_ - 1, static_cast<int>(a / binWidth));
        auto& c = acc[e->cell + static_cast<std::size_t>(bin)];
        if (c < 65535) ++c;
      }
    }
    const auto peak = std::max_element(acc.begin(), acc.end());
    if (*peak == 0) continue;
    const auto cell = static_cast<std::size_t>(peak - acc.begin());
    const std::size_t m = cell / static_cast<std::size_t>(alphaBins_);
    const double alpha = (static_cast<double>(cell % static_cast<std::size_t>(alphaBins_)) + 0.5) * binWidth;
    Vote v;
    v.sceneFromModel = frame.inverse() * rotX(alpha) * frames_[m];
    v.votes = *peak;
    out.push_back(v);
  }
  return out;
}

}  // namespace vgr::vision::cloud
