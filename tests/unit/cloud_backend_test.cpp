// vision/cloud/open3d_backend.hpp: the searches on the bounded nanoflann k-d tree (docs/3d.md
// "Speed") give what an exhaustive search gives: the nearest point, DBSCAN labels as Open3D
// numbers them, and ICP's pairs (its fitness counts exactly the source points whose nearest
// target point lies within the distance with a compatible normal).
#include <cmath>
#include <limits>
#include <random>
#include <vector>

#include <Eigen/Geometry>
#include <gtest/gtest.h>

#include "vision/cloud/open3d_backend.hpp"

namespace {
using namespace vgr::vision::cloud;
using V3 = Eigen::Vector3d;

std::vector<V3> randomPoints(std::size_t n, double extent, unsigned seed) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(-extent, extent);
  std::vector<V3> out;
  for (std::size_t i = 0; i < n; ++i) out.emplace_back(u(rng), u(rng), u(rng));
  return out;
}

std::pair<double, int> bruteNearest(const std::vector<V3>& pts, const V3& q) {
  std::pair<double, int> best{std::numeric_limits<double>::infinity(), -1};
  for (std::size_t i = 0; i < pts.size(); ++i) {
    const double dx = q.x() - pts[i].x(), dy = q.y() - pts[i].y(), dz = q.z() - pts[i].z();
    const double d2 = dx * dx + dy * dy + dz * dz;
    if (d2 < best.first) best = {d2, static_cast<int>(i)};
  }
  return best;
}

TEST(cloud_backend, NearestIndexIsTheExhaustiveNearestPoint) {
  const auto pts = randomPoints(3000, 50, 1);
  const backend::NearestIndex index(pts);
  for (const auto& q : randomPoints(500, 80, 2)) {  // inside and far outside the set
    const auto got = index.nearest(q);
    const auto want = bruteNearest(pts, q);
    EXPECT_EQ(got.second, want.second);
    EXPECT_EQ(got.first, want.first);
  }
  EXPECT_EQ(backend::NearestIndex({}).nearest(V3::Zero()).second, -1);
}

// DBSCAN as Open3D's ClusterDBSCAN: neighbours closer than eps (the point included), a core
// point has >= minPoints of them, clusters numbered by their first point, a border point that
// two clusters reach belongs to the first, -1 for noise.
std::vector<int> referenceDbscan(const std::vector<V3>& pts, double eps, std::size_t minPoints) {
  const std::size_t n = pts.size();
  std::vector<std::vector<std::size_t>> nb(n);
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = 0; j < n; ++j)
      if ((pts[i] - pts[j]).squaredNorm() < eps * eps) nb[i].push_back(j);
  std::vector<int> label(n, -2);
  int next = 0;
  for (std::size_t s = 0; s < n; ++s) {
    if (label[s] != -2) continue;
    if (nb[s].size() < minPoints) {
      label[s] = -1;
      continue;
    }
    std::vector<std::size_t> queue(nb[s]);
    label[s] = next;
    for (std::size_t k = 0; k < queue.size(); ++k) {
      const std::size_t q = queue[k];
      if (label[q] == -1) label[q] = next;
      if (label[q] != -2) continue;
      label[q] = next;
      if (nb[q].size() >= minPoints) queue.insert(queue.end(), nb[q].begin(), nb[q].end());
    }
    ++next;
  }
  return label;
}

TEST(cloud_backend, ClustersAreOpen3dsDbscanLabels) {
  // Blobs of different density plus scattered points: clusters, border points and noise.
  std::vector<V3> pts;
  std::mt19937 rng(3);
  std::normal_distribution<double> g(0, 1);
  for (const V3& c : {V3(0, 0, 0), V3(12, 0, 0), V3(0, 30, 5), V3(40, 40, 40)})
    for (int i = 0; i < 150; ++i) pts.push_back(c + 3 * V3(g(rng), g(rng), g(rng)));
  for (const auto& p : randomPoints(200, 60, 4)) pts.push_back(p);
  for (const double eps : {1.5, 3.0, 6.0})
    for (const int minPoints : {1, 3, 8}) {
      const auto got = backend::PointSet(pts).clusters(eps, minPoints);
      EXPECT_EQ(got, referenceDbscan(pts, eps, static_cast<std::size_t>(minPoints))) << "eps " << eps << " min " << minPoints;
    }
  EXPECT_TRUE(backend::PointSet().clusters(3, 3).empty());
}

TEST(cloud_backend, IcpPairsAreTheExhaustiveNearestPointsWithinTheDistance) {
  // Target: a wavy surface with normals; source: its points moved by a small motion, with
  // the moved normals, plus points far from it. At the returned transform, the fitness must
  // count exactly the source points whose nearest target point is within the distance and
  // whose normal is within the angle.
  std::vector<V3> tp, tn;
  for (double x = -30; x <= 30; x += 1)
    for (double y = -30; y <= 30; y += 1) {
      const double z = 4 * std::sin(x / 9) * std::cos(y / 11);
      tp.emplace_back(x, y, z);
      tn.push_back(V3(-4.0 / 9 * std::cos(x / 9) * std::cos(y / 11), 4.0 / 11 * std::sin(x / 9) * std::sin(y / 11), 1).normalized());
    }
  Eigen::Matrix4d motion = Eigen::Matrix4d::Identity();
  motion.topLeftCorner<3, 3>() = Eigen::AngleAxisd(0.05, V3(0.2, 0.3, 1).normalized()).toRotationMatrix();
  motion.topRightCorner<3, 1>() = V3(1.0, -0.7, 0.5);
  std::vector<V3> sp, sn;
  for (std::size_t i = 0; i < tp.size(); i += 3) {
    sp.push_back((motion * tp[i].homogeneous()).head<3>());
    sn.push_back(motion.topLeftCorner<3, 3>() * tn[i]);
  }
  for (const auto& p : randomPoints(100, 40, 5)) sp.push_back(p + V3(0, 0, 20)), sn.push_back(V3::UnitZ());
  const backend::IcpTarget target(backend::PointSet(tp, tn));
  const backend::PointSet source(sp, sn);
  for (const double maxDist : {0.8, 2.0, 7.5})
    for (const int iterations : {1, 30}) {
      const auto r = target.align(source, maxDist, 30, Eigen::Matrix4d::Identity(), iterations);
      std::size_t pairs = 0;
      for (std::size_t i = 0; i < sp.size(); ++i) {
        const V3 p = (r.transform * sp[i].homogeneous()).head<3>();
        const auto [d2, j] = bruteNearest(tp, p);
        if (d2 > maxDist * maxDist) continue;
        if ((r.transform.topLeftCorner<3, 3>() * sn[i]).dot(tn[static_cast<std::size_t>(j)]) < std::cos(30 * M_PI / 180)) continue;
        ++pairs;
      }
      EXPECT_EQ(r.correspondences, pairs) << "maxDist " << maxDist << " iterations " << iterations;
      if (iterations == 30 && maxDist == 2.0) {
        // and it undid the motion (at 7.5 mm the scattered points pair too and pull it off)
        const Eigen::Matrix4d rest = r.transform * motion;
        const double off = rest.topRightCorner<3, 1>().norm();
        EXPECT_LT(off, 0.05) << maxDist;
      }
    }
}

}  // namespace
