// The one translation unit that includes Open3D (see open3d_backend.hpp). Only the headers
// of what is used, to keep its compile cost down.
#include "vision/cloud/open3d_backend.hpp"

#include <omp.h>

#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <random>
#include <utility>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <nanoflann.hpp>
#include <open3d/geometry/KDTreeFlann.h>
#include <open3d/geometry/PointCloud.h>
#include <open3d/pipelines/registration/CorrespondenceChecker.h>
#include <open3d/pipelines/registration/Feature.h>
#include <open3d/pipelines/registration/GlobalOptimization.h>
#include <open3d/pipelines/registration/GlobalOptimizationConvergenceCriteria.h>
#include <open3d/pipelines/registration/GlobalOptimizationMethod.h>
#include <open3d/pipelines/registration/PoseGraph.h>
#include <open3d/pipelines/registration/Registration.h>
#include <open3d/pipelines/registration/TransformationEstimation.h>
#include <open3d/utility/Logging.h>
#include <open3d/utility/Random.h>

namespace vgr::vision::cloud::backend {

namespace reg = open3d::pipelines::registration;
using open3d::geometry::KDTreeFlann;
using open3d::geometry::KDTreeSearchParamHybrid;
using open3d::geometry::PointCloud;

struct PointSet::Impl {
  PointCloud cloud;
  std::shared_ptr<reg::Feature> features;  // FPFH, 33 x n, or null
};

namespace {

// Open3D prints warnings on stdout (e.g. for a too small correspondence set); our callers
// report what matters themselves.
void quietOpen3d() {
  static const bool once = [] {
    open3d::utility::SetVerbosityLevel(open3d::utility::VerbosityLevel::Error);
    return true;
  }();
  (void)once;
}

// A fixed 3-D point set as nanoflann reads it (the points are not copied).
struct PointsAdaptor {
  const Points* points = nullptr;
  std::size_t kdtree_get_point_count() const { return points->size(); }
  double kdtree_get_pt(std::size_t i, std::size_t d) const { return (*points)[i][static_cast<Eigen::Index>(d)]; }
  template <class Box>
  bool kdtree_get_bbox(Box&) const {
    return false;
  }
};

// The exact nearest-neighbour index of IcpTarget and NearestIndex: nanoflann with the
// dimension fixed at 3 and a distance bound per query. Open3D's KDTreeFlann (nanoflann with a
// run-time dimension, a std::vector result per call, no bound) took 47 % of a locate() call
// in ICP's pairing (callgrind, bracket scenes 100-102; docs/3d.md "Speed").
class Tree3 {
 public:
  explicit Tree3(const Points& points)
      : adaptor_{&points}, tree_(3, adaptor_, nanoflann::KDTreeSingleIndexAdaptorParams(10)) {}
  // The nearest point closer than sqrt(bound2) (strictly): its index and squared distance
  // (the sum of the squared coordinate differences, x, y, z in that order, as Open3D's); -1
  // when none is. Exact: the bound only prunes the search.
  int nearest(const Eigen::Vector3d& p, double bound2, double& d2) const {
    nanoflann::KNNResultSet<double, std::uint32_t> result(1);
    std::uint32_t index = 0;
    double dist = 0;
    result.init(&index, &dist);
    dist = bound2;  // the result set's worst distance: only closer points are added
    tree_.findNeighbors(result, p.data(), nanoflann::SearchParams());
    if (result.size() == 0) return -1;
    d2 = dist;
    return static_cast<int>(index);
  }
  // The points closer than sqrt(radius2) (strictly, as Open3D's radius search), with their
  // squared distances; nearest first when `sorted`.
  void within(const Eigen::Vector3d& p, double radius2, std::vector<std::pair<std::uint32_t, double>>& out, bool sorted) const {
    tree_.radiusSearch(p.data(), radius2, out, nanoflann::SearchParams(32, 0, sorted));
  }

 private:
  using Index = nanoflann::KDTreeSingleIndexAdaptor<nanoflann::L2_Simple_Adaptor<double, PointsAdaptor>, PointsAdaptor, 3, std::uint32_t>;
  PointsAdaptor adaptor_;
  Index tree_;
};

// The squared distance as Tree3 computes it (same order of operations).
double squaredDistance(const Eigen::Vector3d& a, const Eigen::Vector3d& b) {
  const double dx = a.x() - b.x(), dy = a.y() - b.y(), dz = a.z() - b.z();
  return dx * dx + dy * dy + dz * dz;
}

Registration fromResult(const reg::RegistrationResult& r) {
  Registration out;
  out.transform = r.transformation_;
  out.fitness = r.fitness_;
  out.rmseMm = r.inlier_rmse_;
  out.correspondences = r.correspondence_set_.size();
  return out;
}

}  // namespace

void setThreads(int n) {
  quietOpen3d();
  omp_set_num_threads(std::clamp(n, 1, 64));
}

void seedRandom(unsigned seed) { open3d::utility::random::Seed(static_cast<int>(seed & 0x7fffffffu)); }

PointSet::PointSet() : impl_(std::make_unique<Impl>()) { quietOpen3d(); }
PointSet::PointSet(Points points, Points normals) : PointSet() {
  impl_->cloud.points_ = std::move(points);
  impl_->cloud.normals_ = std::move(normals);
}
PointSet::~PointSet() = default;
PointSet::PointSet(PointSet&&) noexcept = default;
PointSet& PointSet::operator=(PointSet&&) noexcept = default;

std::size_t PointSet::size() const { return impl_->cloud.points_.size(); }
const Points& PointSet::points() const { return impl_->cloud.points_; }
const Points& PointSet::normals() const { return impl_->cloud.normals_; }
bool PointSet::hasFeatures() const { return impl_->features && impl_->features->Num() == size(); }

PointSet PointSet::voxelDown(double voxelMm) const {
  // Open3D's voxel grid averages the points and normals of each voxel (paper 004's voxelised model).
  PointSet out;
  out.impl_->cloud = *impl_->cloud.VoxelDownSample(voxelMm);
  if (out.impl_->cloud.HasNormals()) out.impl_->cloud.NormalizeNormals();
  return out;
}

PointSet PointSet::select(const std::vector<std::size_t>& indices) const {
  PointSet out;
  out.impl_->cloud = *impl_->cloud.SelectByIndex(indices);
  if (hasFeatures()) {
    out.impl_->features = std::make_shared<reg::Feature>();
    out.impl_->features->Resize(static_cast<int>(impl_->features->Dimension()), static_cast<int>(indices.size()));
    for (std::size_t k = 0; k < indices.size(); ++k)
      out.impl_->features->data_.col(static_cast<Eigen::Index>(k)) = impl_->features->data_.col(static_cast<Eigen::Index>(indices[k]));
  }
  return out;
}

PointSet PointSet::transformed(const Eigen::Matrix4d& t) const {
  PointSet out;
  out.impl_->cloud = impl_->cloud;
  out.impl_->cloud.Transform(t);
  out.impl_->features = impl_->features;  // FPFH is invariant to rigid motion
  return out;
}

void PointSet::transform(const Eigen::Matrix4d& t) { impl_->cloud.Transform(t); }

void PointSet::estimateNormals(double radiusMm, int maxNn, const Eigen::Vector3d& viewpoint) {
  impl_->cloud.EstimateNormals(KDTreeSearchParamHybrid(radiusMm, maxNn));
  impl_->cloud.OrientNormalsTowardsCameraLocation(viewpoint);
}

void PointSet::reestimateNormals(double radiusMm, int maxNn) {
  const Points old = impl_->cloud.normals_;
  impl_->cloud.EstimateNormals(KDTreeSearchParamHybrid(radiusMm, maxNn));
  if (old.size() != impl_->cloud.normals_.size()) return;
  for (std::size_t i = 0; i < old.size(); ++i)
    if (impl_->cloud.normals_[i].dot(old[i]) < 0) impl_->cloud.normals_[i] = -impl_->cloud.normals_[i];
}

void PointSet::computeFpfh(double radiusMm, int maxNn) {
  impl_->features = reg::ComputeFPFHFeature(impl_->cloud, KDTreeSearchParamHybrid(radiusMm, maxNn));
}

void PointSet::estimateNormalsFrom(const PointSet& dense, double radiusMm, const Eigen::Vector3d& viewpoint) {
  auto& cloud = impl_->cloud;
  cloud.normals_.assign(cloud.points_.size(), Eigen::Vector3d::UnitZ());
  if (dense.size() == 0) return;
  // The 60 nearest dense points within radiusMm (Open3D's hybrid search: the sorted radius
  // search cut at 60), on Tree3.
  constexpr std::size_t maxNn = 60;
  const auto& dp = dense.points();
  const Tree3 tree(dp);
  std::vector<std::pair<std::uint32_t, double>> found;
  for (std::size_t i = 0; i < cloud.points_.size(); ++i) {
    const Eigen::Vector3d& p = cloud.points_[i];
    tree.within(p, radiusMm * radiusMm, found, true);
    if (found.size() > maxNn) found.resize(maxNn);
    if (found.size() < 3) {
      cloud.normals_[i] = (viewpoint - p).normalized();
      continue;
    }
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (const auto& f : found) mean += dp[f.first];
    mean /= static_cast<double>(found.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (const auto& f : found) {
      const Eigen::Vector3d d = dp[f.first] - mean;
      cov += d * d.transpose();
    }
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d> eig(cov);
    Eigen::Vector3d n = eig.eigenvectors().col(0);
    if (n.dot(viewpoint - p) < 0) n = -n;
    cloud.normals_[i] = n;
  }
}

void PointSet::setNormals(Points normals) { impl_->cloud.normals_ = std::move(normals); }

void PointSet::normalsFromNearest(const PointSet& dense) {
  auto& cloud = impl_->cloud;
  if (dense.size() == 0 || dense.normals().size() != dense.size()) return;
  KDTreeFlann tree(dense.impl().cloud);
  std::vector<int> idx(1);
  std::vector<double> d2(1);
  cloud.normals_.resize(cloud.points_.size());
  for (std::size_t i = 0; i < cloud.points_.size(); ++i)
    if (tree.SearchKNN(cloud.points_[i], 1, idx, d2) > 0) cloud.normals_[i] = dense.normals()[static_cast<std::size_t>(idx[0])];
}

std::vector<double> PointSet::surfaceVariation(double radiusMm) const {
  std::vector<double> out(size(), 0.0);
  if (size() == 0) return out;
  KDTreeFlann tree(impl_->cloud);
  std::vector<int> idx;
  std::vector<double> d2;
  const auto& pts = impl_->cloud.points_;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    if (tree.SearchRadius(pts[i], radiusMm, idx, d2) < 4) continue;
    Eigen::Vector3d mean = Eigen::Vector3d::Zero();
    for (int j : idx) mean += pts[static_cast<std::size_t>(j)];
    mean /= static_cast<double>(idx.size());
    Eigen::Matrix3d cov = Eigen::Matrix3d::Zero();
    for (int j : idx) {
      const Eigen::Vector3d d = pts[static_cast<std::size_t>(j)] - mean;
      cov += d * d.transpose();
    }
    const Eigen::Vector3d ev = Eigen::SelfAdjointEigenSolver<Eigen::Matrix3d>(cov, Eigen::EigenvaluesOnly).eigenvalues();
    const double sum = ev.sum();
    out[i] = sum > 0 ? ev[0] / sum : 0;
  }
  return out;
}

void PointSet::setFeaturesFrom(const std::vector<PointSet>& parts) {
  auto f = std::make_shared<reg::Feature>();
  std::size_t n = 0;
  for (const auto& p : parts) n += p.size();
  f->Resize(33, static_cast<int>(n));
  Eigen::Index at = 0;
  for (const auto& p : parts) {
    if (!p.hasFeatures()) continue;
    f->data_.middleCols(at, static_cast<Eigen::Index>(p.size())) = p.impl_->features->data_;
    at += static_cast<Eigen::Index>(p.size());
  }
  impl_->features = f;
}

std::vector<int> PointSet::clusters(double epsMm, int minPoints) const {
  // DBSCAN labelled as Open3D's ClusterDBSCAN labels it (same neighbours: the points closer
  // than eps, the point itself included; clusters numbered by their first point; a border
  // point two clusters reach belongs to the first), on Tree3: Open3D's took 10 % of a
  // locate() call (callgrind, bracket 100-102), most of it in its k-d tree.
  const auto& pts = impl_->cloud.points_;
  if (pts.empty()) return {};
  const auto minPts = static_cast<std::size_t>(std::max(1, minPoints));
  const Tree3 tree(pts);
  std::vector<std::uint32_t> first(pts.size() + 1, 0), neighbours;
  std::vector<std::pair<std::uint32_t, double>> found;
  for (std::size_t i = 0; i < pts.size(); ++i) {
    tree.within(pts[i], epsMm * epsMm, found, false);
    first[i] = static_cast<std::uint32_t>(neighbours.size());
    for (const auto& f : found) neighbours.push_back(f.first);
  }
  first[pts.size()] = static_cast<std::uint32_t>(neighbours.size());
  auto count = [&](std::size_t i) { return static_cast<std::size_t>(first[i + 1] - first[i]); };
  std::vector<int> labels(pts.size(), -2);  // -2 not visited, -1 noise
  std::vector<std::uint32_t> open;
  int label = 0;
  for (std::size_t seed = 0; seed < pts.size(); ++seed) {
    if (labels[seed] != -2) continue;
    if (count(seed) < minPts) {
      labels[seed] = -1;
      continue;
    }
    labels[seed] = label;
    open.assign(neighbours.begin() + first[seed], neighbours.begin() + first[seed + 1]);
    while (!open.empty()) {
      const std::uint32_t q = open.back();
      open.pop_back();
      if (labels[q] == -1) labels[q] = label;  // a border point, not expanded
      if (labels[q] != -2) continue;
      labels[q] = label;
      if (count(q) >= minPts)
        for (std::uint32_t j = first[q]; j < first[q + 1]; ++j)
          if (labels[neighbours[j]] < 0) open.push_back(neighbours[j]);
    }
    ++label;
  }
  return labels;
}

PointSet::Plane PointSet::segmentPlane(double distanceMm, int iterations) const {
  Plane p;
  if (size() < 3) return p;
  auto [model, inliers] = impl_->cloud.SegmentPlane(distanceMm, 3, iterations);
  const double n = model.head<3>().norm();
  if (n > 0) model /= n;
  p.coefficients = model;
  p.inliers = std::move(inliers);
  return p;
}

struct FeatureIndex::Impl {
  reg::Feature features;
  KDTreeFlann tree;
};

FeatureIndex::FeatureIndex(const PointSet& indexed) : impl_(std::make_unique<Impl>()) {
  if (!indexed.hasFeatures()) return;
  impl_->features = *indexed.impl().features;
  impl_->tree.SetFeature(impl_->features);
}
FeatureIndex::~FeatureIndex() = default;

std::vector<Eigen::Vector2i> FeatureIndex::match(const PointSet& query, const std::vector<std::size_t>& subset, int k,
                                                 std::vector<double>* distances) const {
  std::vector<Eigen::Vector2i> out;
  if (distances) distances->clear();
  if (!query.hasFeatures() || impl_->features.Num() == 0) return out;
  const reg::Feature& fq = *query.impl().features;
  std::vector<int> idx;
  std::vector<double> d2;
  auto one = [&](std::size_t i) {
    const int n = impl_->tree.SearchKNN(Eigen::VectorXd(fq.data_.col(static_cast<Eigen::Index>(i))), std::max(1, k), idx, d2);
    for (int j = 0; j < n; ++j) {
      out.emplace_back(static_cast<int>(i), idx[static_cast<std::size_t>(j)]);
      if (distances) distances->push_back(std::sqrt(d2[static_cast<std::size_t>(j)]));
    }
  };
  if (subset.empty())
    for (std::size_t i = 0; i < query.size(); ++i) one(i);
  else
    for (std::size_t i : subset) one(i);
  return out;
}

struct CorrespondenceSampler::Impl {
  const PointSet* scene = nullptr;
  std::vector<std::vector<int>> modelOf;     // per scene point: model indices it corresponds to
  std::vector<std::vector<int>> neighbours;  // per scene point: scene points within the neighbourhood
  std::vector<int> withCorres;               // scene points that have a correspondence
};

CorrespondenceSampler::CorrespondenceSampler(const PointSet& scene, const std::vector<Eigen::Vector2i>& sceneToModel,
                                             double neighbourhoodMm)
    : impl_(std::make_unique<Impl>()) {
  impl_->scene = &scene;
  impl_->modelOf.resize(scene.size());
  for (const auto& c : sceneToModel) impl_->modelOf[static_cast<std::size_t>(c[0])].push_back(c[1]);
  for (std::size_t i = 0; i < scene.size(); ++i)
    if (!impl_->modelOf[i].empty()) impl_->withCorres.push_back(static_cast<int>(i));
  impl_->neighbours.resize(scene.size());
  if (scene.size() == 0) return;
  KDTreeFlann tree(scene.impl().cloud);
  std::vector<int> idx;
  std::vector<double> d2;
  for (int i : impl_->withCorres) {
    tree.SearchRadius(scene.points()[static_cast<std::size_t>(i)], neighbourhoodMm, idx, d2);
    auto& nb = impl_->neighbours[static_cast<std::size_t>(i)];
    for (int j : idx)
      if (j != i && !impl_->modelOf[static_cast<std::size_t>(j)].empty()) nb.push_back(j);
  }
}
CorrespondenceSampler::~CorrespondenceSampler() = default;

std::vector<CorrespondenceSampler::Hypothesis> CorrespondenceSampler::run(const PointSet& model, const std::vector<char>& active,
                                                                          const Settings& st,
                                                                          const std::function<double(const Eigen::Matrix4d&)>& score) const {
  std::vector<Hypothesis> top;
  const auto& with = impl_->withCorres;
  if (with.empty()) return top;
  const PointCloud& src = model.impl().cloud;
  const PointCloud& tgt = impl_->scene->impl().cloud;
  const reg::TransformationEstimationPointToPoint estimate(false);
  const reg::CorrespondenceCheckerBasedOnEdgeLength edge(st.edgeSimilarity);
  const reg::CorrespondenceCheckerBasedOnDistance distance(st.distanceMm);
  std::mt19937 rng(st.seed);
  reg::CorrespondenceSet three(3);  // (model, scene)
  auto pick = [&](const std::vector<int>& v) { return v[rng() % v.size()]; };
  auto isActive = [&](int i) { return active.empty() || active[static_cast<std::size_t>(i)]; };
  auto near = [](const Eigen::Matrix4d& a, const Eigen::Matrix4d& b) {
    const Eigen::Matrix3d d = a.topLeftCorner<3, 3>().transpose() * b.topLeftCorner<3, 3>();
    const double angle = std::acos(std::clamp((d.trace() - 1) / 2, -1.0, 1.0));
    return (a.topRightCorner<3, 1>() - b.topRightCorner<3, 1>()).norm() < 10 && angle < 10 * M_PI / 180;
  };
  auto consider = [&](const Eigen::Matrix4d& t) {
    const double sc = score(t);
    bool merged = false;
    for (auto& h : top)
      if (near(h.transform, t)) {
        if (sc > h.score) h = {t, sc};
        merged = true;
        break;
      }
    if (!merged) top.push_back({t, sc});
    std::sort(top.begin(), top.end(), [](const Hypothesis& x, const Hypothesis& y) { return x.score > y.score; });
    if (static_cast<int>(top.size()) > st.keep) top.pop_back();
  };
  const bool pairs = st.sampleSize == 2 && src.HasNormals() && tgt.HasNormals();
  const double cosNormal = std::cos(st.normalAngleDeg * M_PI / 180.0);
  reg::CorrespondenceSet two(2);
  for (int it = 0; it < st.iterations; ++it) {
    const int a = pick(with);
    if (!isActive(a)) continue;
    const auto& nb = impl_->neighbours[static_cast<std::size_t>(a)];
    if (nb.size() < 2) continue;
    Eigen::Matrix4d t;
    if (pairs) {
      // Every combination of the two points' model matches whose pair geometry agrees: the
      // ratio of the distances (Open3D's edge-length checker) and the angles of each normal
      // to the connecting line and between the normals (PPF-style, Drost et al. 2010).
      const int b = pick(nb);
      if (!isActive(b)) continue;
      const auto& pt0 = tgt.points_[static_cast<std::size_t>(a)];
      const auto& pt1 = tgt.points_[static_cast<std::size_t>(b)];
      const auto& nt0 = tgt.normals_[static_cast<std::size_t>(a)];
      const auto& nt1 = tgt.normals_[static_cast<std::size_t>(b)];
      const Eigen::Vector3d dt = pt1 - pt0;
      const double lt = dt.norm();
      if (lt < 6) continue;
      auto angle = [](const Eigen::Vector3d& x, const Eigen::Vector3d& y) {
        return std::acos(std::clamp(x.dot(y) / (x.norm() * y.norm()), -1.0, 1.0));
      };
      const double at0 = angle(nt0, dt), at1 = angle(nt1, dt), at01 = angle(nt0, nt1);
      const double tolAngle = std::acos(cosNormal);
      for (int ma : impl_->modelOf[static_cast<std::size_t>(a)])
        for (int mb : impl_->modelOf[static_cast<std::size_t>(b)]) {
          if (ma == mb) continue;
          const auto& ps0 = src.points_[static_cast<std::size_t>(ma)];
          const auto& ps1 = src.points_[static_cast<std::size_t>(mb)];
          const Eigen::Vector3d ds = ps1 - ps0;
          const double ls = ds.norm();
          if (ls < st.edgeSimilarity * lt || lt < st.edgeSimilarity * ls) continue;
          const auto& ns0 = src.normals_[static_cast<std::size_t>(ma)];
          const auto& ns1 = src.normals_[static_cast<std::size_t>(mb)];
          if (std::abs(angle(ns0, ds) - at0) > tolAngle || std::abs(angle(ns1, ds) - at1) > tolAngle ||
              std::abs(angle(ns0, ns1) - at01) > tolAngle)
            continue;
          Eigen::Matrix<double, 3, 4> from, to;
          from << ps0, ps1, ps0 + 10 * ns0, ps1 + 10 * ns1;
          to << pt0, pt1, pt0 + 10 * nt0, pt1 + 10 * nt1;
          const Eigen::Matrix4d t2 = Eigen::umeyama(from, to, false);
          two[0] = Eigen::Vector2i(ma, a);
          two[1] = Eigen::Vector2i(mb, b);
          if (!distance.Check(src, tgt, two, t2)) continue;
          consider(t2);
        }
      continue;
    } else {
      const int b = pick(nb), c = pick(nb);
      if (b == c || !isActive(b) || !isActive(c)) continue;
      three[0] = Eigen::Vector2i(pick(impl_->modelOf[static_cast<std::size_t>(a)]), a);
      three[1] = Eigen::Vector2i(pick(impl_->modelOf[static_cast<std::size_t>(b)]), b);
      three[2] = Eigen::Vector2i(pick(impl_->modelOf[static_cast<std::size_t>(c)]), c);
      if (!edge.Check(src, tgt, three, Eigen::Matrix4d::Identity())) continue;  // needs no estimate: cheap first
      t = estimate.ComputeTransformation(src, tgt, three);
      if (!distance.Check(src, tgt, three, t)) continue;
    }
    consider(t);
  }
  return top;
}

std::vector<Eigen::Vector2i> featureCorrespondences(const PointSet& source, const PointSet& target, bool mutualFilter) {
  std::vector<Eigen::Vector2i> out;
  if (!source.hasFeatures() || !target.hasFeatures() || target.size() == 0) return out;
  const reg::Feature& fs = *source.impl().features;
  const reg::Feature& ft = *target.impl().features;
  KDTreeFlann toTarget(ft);
  std::vector<int> idx(1);
  std::vector<double> d2(1);
  std::vector<int> forward(source.size(), -1);
  for (std::size_t i = 0; i < source.size(); ++i)
    if (toTarget.SearchKNN(Eigen::VectorXd(fs.data_.col(static_cast<Eigen::Index>(i))), 1, idx, d2) > 0)
      forward[i] = idx[0];
  std::vector<int> backward;
  if (mutualFilter) {
    KDTreeFlann toSource(fs);
    backward.assign(target.size(), -1);
    for (std::size_t j = 0; j < target.size(); ++j)
      if (toSource.SearchKNN(Eigen::VectorXd(ft.data_.col(static_cast<Eigen::Index>(j))), 1, idx, d2) > 0) backward[j] = idx[0];
  }
  for (std::size_t i = 0; i < source.size(); ++i) {
    const int j = forward[i];
    if (j < 0) continue;
    if (mutualFilter && backward[static_cast<std::size_t>(j)] != static_cast<int>(i)) continue;
    out.emplace_back(static_cast<int>(i), j);
  }
  return out;
}

Registration ransacOnCorrespondences(const PointSet& source, const PointSet& target, const std::vector<Eigen::Vector2i>& corres,
                                     double maxDistanceMm, double edgeSimilarity, int maxIterations, double confidence,
                                     double normalAngleDeg) {
  const reg::CorrespondenceCheckerBasedOnEdgeLength edge(edgeSimilarity);
  const reg::CorrespondenceCheckerBasedOnDistance distance(maxDistanceMm);
  const reg::CorrespondenceCheckerBasedOnNormal normal(normalAngleDeg * M_PI / 180.0);
  std::vector<std::reference_wrapper<const reg::CorrespondenceChecker>> checkers{std::cref<reg::CorrespondenceChecker>(edge),
                                                                                  std::cref<reg::CorrespondenceChecker>(distance)};
  if (normalAngleDeg > 0 && source.impl().cloud.HasNormals() && target.impl().cloud.HasNormals())
    checkers.push_back(std::cref<reg::CorrespondenceChecker>(normal));
  const reg::CorrespondenceSet set(corres.begin(), corres.end());
  const auto r = reg::RegistrationRANSACBasedOnCorrespondence(source.impl().cloud, target.impl().cloud, set, maxDistanceMm,
                                                              reg::TransformationEstimationPointToPoint(false), 3, checkers,
                                                              reg::RANSACConvergenceCriteria(maxIterations, confidence));
  return fromResult(r);
}

Registration icpPointToPlane(const PointSet& source, const PointSet& target, double maxDistanceMm, const Eigen::Matrix4d& init,
                             int maxIterations) {
  if (source.size() == 0 || target.size() == 0 || !target.impl().cloud.HasNormals()) {
    Registration none;
    none.transform = init;
    return none;
  }
  const auto r = reg::RegistrationICP(source.impl().cloud, target.impl().cloud, maxDistanceMm, init,
                                      reg::TransformationEstimationPointToPlane(), reg::ICPConvergenceCriteria(1e-7, 1e-7, maxIterations));
  return fromResult(r);
}

struct IcpTarget::Impl {
  PointCloud cloud;
  std::unique_ptr<Tree3> tree;
};

IcpTarget::IcpTarget(const PointSet& target) : impl_(std::make_unique<Impl>()) {
  impl_->cloud = target.impl().cloud;
  if (!impl_->cloud.points_.empty()) impl_->tree = std::make_unique<Tree3>(impl_->cloud.points_);
}
IcpTarget::~IcpTarget() = default;

Registration IcpTarget::align(const PointSet& source, double maxDist, double maxAngleDeg, const Eigen::Matrix4d& init,
                              int iterations, const Eigen::Vector3d& pivot, double minEigenShare) const {
  Registration out;
  out.transform = init;
  const auto& sp = source.points();
  const auto& sn = source.normals();
  const auto& tp = impl_->cloud.points_;
  const auto& tn = impl_->cloud.normals_;
  if (sp.empty() || tp.empty() || sn.size() != sp.size() || tn.size() != tp.size()) return out;
  const double cosMin = std::cos(maxAngleDeg * M_PI / 180.0);
  const double max2 = maxDist * maxDist;
  Eigen::Matrix4d t = init;
  // Pairs: each source point's nearest target point within maxDist (the same pairs as an
  // unbounded nearest-neighbour search followed by the distance test). The search is bounded
  // by maxDist and, from the second pass on, by the distance to the point's previous partner
  // (the estimate moves little between steps): the nearest point is never farther.
  const double bound = std::nextafter(max2, std::numeric_limits<double>::infinity());
  std::vector<int> partner(sp.size(), -1);
  auto pairUp = [&](const Eigen::Matrix4d& cur, auto&& visit) {
    const Eigen::Matrix3d r = cur.topLeftCorner<3, 3>();
    const Eigen::Vector3d tr = cur.topRightCorner<3, 1>();
    for (std::size_t i = 0; i < sp.size(); ++i) {
      const Eigen::Vector3d p = r * sp[i] + tr;
      double b = bound;
      if (partner[i] >= 0) b = std::min(b, squaredDistance(p, tp[static_cast<std::size_t>(partner[i])]) * (1 + 1e-9) + 1e-12);
      double d2 = 0;
      partner[i] = impl_->tree->nearest(p, b, d2);
      if (partner[i] < 0) continue;
      const auto j = static_cast<std::size_t>(partner[i]);
      if ((r * sn[i]).dot(tn[j]) < cosMin) continue;
      visit(p, tp[j], tn[j], d2);
    }
  };
  for (int it = 0; it < iterations; ++it) {
    Eigen::Matrix<double, 6, 6> jtj = Eigen::Matrix<double, 6, 6>::Zero();
    Eigen::Matrix<double, 6, 1> jtr = Eigen::Matrix<double, 6, 1>::Zero();
    std::size_t n = 0;
    double arm2 = 0;
    // Rotation about the pivot (the model's centroid): p' = R (p - c) + c + t.
    pairUp(t, [&](const Eigen::Vector3d& p, const Eigen::Vector3d& q, const Eigen::Vector3d& nq, double) {
      Eigen::Matrix<double, 6, 1> j;
      j.head<3>() = (p - pivot).cross(nq);
      j.tail<3>() = nq;
      const double res = (p - q).dot(nq);
      jtj.noalias() += j * j.transpose();
      jtr.noalias() += j * res;
      arm2 += (p - pivot).squaredNorm();
      ++n;
    });
    if (n < 6) break;
    Eigen::Matrix<double, 6, 1> x;
    if (minEigenShare > 0) {
      // Degeneracy-aware step (header): in scaled parameters (rotation x arm, mm) solve only
      // along the well-determined eigen-directions.
      const double arm = std::max(1.0, std::sqrt(arm2 / static_cast<double>(n)));
      Eigen::Matrix<double, 6, 1> sc;
      sc << 1 / arm, 1 / arm, 1 / arm, 1, 1, 1;
      const Eigen::Matrix<double, 6, 6> a = sc.asDiagonal() * jtj * sc.asDiagonal();
      const Eigen::Matrix<double, 6, 1> g = sc.asDiagonal() * jtr;
      const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(a);
      const double top = eig.eigenvalues()[5];
      Eigen::Matrix<double, 6, 1> y = Eigen::Matrix<double, 6, 1>::Zero();
      for (int e = 0; e < 6; ++e)
        if (eig.eigenvalues()[e] > minEigenShare * top && eig.eigenvalues()[e] > 0)
          y -= eig.eigenvectors().col(e) * (eig.eigenvectors().col(e).dot(g) / eig.eigenvalues()[e]);
      x = sc.asDiagonal() * y;
    } else {
      x = jtj.ldlt().solve(-jtr);
    }
    if (!x.allFinite()) break;
    // A step longer than half the pairing distance (or 5 deg) is cut to it: with few pairs or
    // one dominant plane, J^T J is near singular along the plane and an unclamped
    // Gauss-Newton step threw a pose 4 mm / 3 deg off to 42 mm / 55 deg (lever scene 107).
    const double scale = std::min({1.0, 0.5 * maxDist / std::max(1e-12, x.tail<3>().norm()),
                                   (5 * M_PI / 180) / std::max(1e-12, x.head<3>().norm())});
    x *= scale;
    Eigen::Matrix4d step = Eigen::Matrix4d::Identity();
    const double angle = x.head<3>().norm();
    if (angle > 0) step.topLeftCorner<3, 3>() = Eigen::AngleAxisd(angle, x.head<3>() / angle).toRotationMatrix();
    step.topRightCorner<3, 1>() = pivot - step.topLeftCorner<3, 3>() * pivot + x.tail<3>();
    t = step * t;
    if (x.tail<3>().norm() < 1e-3 && angle < 1e-6) break;
  }
  std::size_t n = 0;
  double sum = 0;
  pairUp(t, [&](const Eigen::Vector3d&, const Eigen::Vector3d& q, const Eigen::Vector3d& nq, double dd) {
    sum += dd;
    ++n;
    Eigen::Matrix<double, 6, 1> j;
    j.head<3>() = (q - pivot).cross(nq);
    j.tail<3>() = nq;
    out.hessian.noalias() += j * j.transpose();
  });
  out.transform = t;
  out.correspondences = n;
  out.fitness = static_cast<double>(n) / static_cast<double>(sp.size());
  out.rmseMm = n ? std::sqrt(sum / static_cast<double>(n)) : 0;
  return out;
}

Registration evaluate(const PointSet& source, const PointSet& target, double maxDistanceMm, const Eigen::Matrix4d& transform) {
  if (source.size() == 0 || target.size() == 0) {
    Registration none;
    none.transform = transform;
    return none;
  }
  return fromResult(reg::EvaluateRegistration(source.impl().cloud, target.impl().cloud, maxDistanceMm, transform));
}

Eigen::Matrix<double, 6, 6> informationMatrix(const PointSet& source, const PointSet& target, double maxDistanceMm,
                                              const Eigen::Matrix4d& transform) {
  return reg::GetInformationMatrixFromPointClouds(source.impl().cloud, target.impl().cloud, maxDistanceMm, transform);
}

PoseGraphResult optimisePoseGraph(const std::vector<Eigen::Matrix4d>& nodes, const std::vector<PoseGraphEdge>& edges,
                                  double maxCorrespondenceMm, double edgePruneThreshold, int reference) {
  quietOpen3d();
  reg::PoseGraph graph;
  for (const auto& n : nodes) graph.nodes_.emplace_back(n);
  for (const auto& e : edges) graph.edges_.emplace_back(e.source, e.target, e.transform, e.information, e.uncertain, 1.0);
  reg::GlobalOptimization(graph, reg::GlobalOptimizationLevenbergMarquardt(), reg::GlobalOptimizationConvergenceCriteria(),
                          reg::GlobalOptimizationOption(maxCorrespondenceMm, edgePruneThreshold, 1.0, reference));
  PoseGraphResult out;
  for (const auto& n : graph.nodes_) out.nodes.push_back(n.pose_);
  std::map<std::pair<int, int>, int> kept;
  for (const auto& e : graph.edges_) ++kept[{e.source_node_id_, e.target_node_id_}];
  for (const auto& e : edges) {
    auto it = kept.find({e.source, e.target});
    const bool k = it != kept.end() && it->second > 0;
    if (k) --it->second;
    out.edgeKept.push_back(k);
  }
  return out;
}

struct NearestIndex::Impl {
  Points points;
  std::unique_ptr<Tree3> tree;
};

NearestIndex::NearestIndex(const Points& points) : impl_(std::make_unique<Impl>()) {
  impl_->points = points;
  if (!points.empty()) impl_->tree = std::make_unique<Tree3>(impl_->points);
}
NearestIndex::~NearestIndex() = default;

std::pair<double, int> NearestIndex::nearest(const Eigen::Vector3d& p) const {
  if (!impl_->tree) return {std::numeric_limits<double>::infinity(), -1};
  double d2 = 0;
  const int i = impl_->tree->nearest(p, std::numeric_limits<double>::infinity(), d2);
  if (i < 0) return {std::numeric_limits<double>::infinity(), -1};
  return {d2, i};
}

}  // namespace vgr::vision::cloud::backend
