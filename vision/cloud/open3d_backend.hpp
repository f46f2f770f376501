// The only door to Open3D (0.16, Debian libopen3d-dev): every Open3D call of vgr is in
// open3d_backend.cpp, the one translation unit that includes Open3D headers (~4 s and
// ~300 MB to compile, PITFALLS.md). Internal to vision/cloud/: Eigen types only, so the
// locator and the model builder compile without Open3D. Units: mm.
//
// Paper 004's building blocks, each cited where it is implemented: point clouds from depth,
// voxel down-sampling, normals, plane RANSAC, FPFH [35], RANSAC on feature correspondences
// [36] with edge-length and distance checkers, point-to-plane ICP (eq. 2), the information
// matrix of a registered pair, and multiway registration by pose graph (Sec. 3.1, [32, 34]).
//
// Thread: objects are used by one thread at a time. setThreads() bounds OpenMP for the
// calling thread (call it before each job's work; vgrd's cycle thread does).
#pragma once

#include <cstddef>
#include <functional>
#include <memory>
#include <vector>

#include <Eigen/Core>

namespace vgr::vision::cloud::backend {

using Points = std::vector<Eigen::Vector3d>;

// OpenMP threads for Open3D's loops on this thread (omp_set_num_threads), [1, 64]; and
// Open3D's global random seed (RANSAC, plane segmentation).
void setThreads(int n);
void seedRandom(unsigned seed);

// A point cloud (points, optional unit normals, optional FPFH features), owning its Open3D
// object. Move-only.
class PointSet {
 public:
  PointSet();
  PointSet(Points points, Points normals = {});
  ~PointSet();
  PointSet(PointSet&&) noexcept;
  PointSet& operator=(PointSet&&) noexcept;

  std::size_t size() const;
  const Points& points() const;
  const Points& normals() const;  // empty when it has none
  bool hasFeatures() const;

  // Voxel grid of `voxelMm`: one point per occupied voxel, the mean of its points (and
  // normals, re-normalised). Features are not carried over.
  PointSet voxelDown(double voxelMm) const;
  // The points at `indices` (with normals and features).
  PointSet select(const std::vector<std::size_t>& indices) const;
  PointSet transformed(const Eigen::Matrix4d& t) const;  // features carried over (they are invariant)
  void transform(const Eigen::Matrix4d& t);

  // Normals from the covariance of neighbours within radiusMm (at most maxNn), turned towards
  // `viewpoint` (the camera centre): a depth view sees only surfaces facing it.
  void estimateNormals(double radiusMm, int maxNn, const Eigen::Vector3d& viewpoint);
  // The same estimate for a cloud that has normals already (a model's, outward): each new
  // normal is turned to the side of the old one. Model and view then get features from the
  // same normal estimate (FPFH is sensitive to how normals bend at edges).
  void reestimateNormals(double radiusMm, int maxNn);
  // FPFH (Rusu 2009, paper 004 [35]) over neighbours within radiusMm (at most maxNn).
  void computeFpfh(double radiusMm, int maxNn);
  // Normals from a denser cloud: PCA over the dense points within radiusMm of each point,
  // turned towards `viewpoint`. A 3 mm voxel cloud's own neighbours (6 mm radius) blend the
  // faces of an 8 mm plate; the sensor's full-resolution points at 2.5 mm do not (measured:
  // 45 % -> 90 % of normals within 15 deg of the true ones on the bracket).
  void estimateNormalsFrom(const PointSet& dense, double radiusMm, const Eigen::Vector3d& viewpoint);
  // Replaces the normals (one per point).
  void setNormals(Points normals);
  // Each point takes the normal of the nearest point of `dense` (which has normals): the
  // model's exact normals carried onto its voxel grid without averaging across edges.
  void normalsFromNearest(const PointSet& dense);

  // Surface variation lambda_0 / (lambda_0 + lambda_1 + lambda_2) of the covariance of the
  // neighbours within radiusMm (Pauly et al. 2002): 0 on a plane, up to 1/3 at corners.
  std::vector<double> surfaceVariation(double radiusMm) const;
  // Features of this set = the features of `parts` concatenated (sizes must add up).
  void setFeaturesFrom(const std::vector<PointSet>& parts);

  // Euclidean clusters (DBSCAN, Ester et al. 1996): label per point, -1 for noise.
  std::vector<int> clusters(double epsMm, int minPoints) const;

  // RANSAC plane: (a, b, c, d) with a x + b y + c z + d = 0, |(a, b, c)| = 1, and its inliers.
  struct Plane {
    Eigen::Vector4d coefficients = Eigen::Vector4d::Zero();
    std::vector<std::size_t> inliers;
  };
  Plane segmentPlane(double distanceMm, int iterations) const;

  struct Impl;
  Impl& impl() const { return *impl_; }

 private:
  std::unique_ptr<Impl> impl_;
};

// A k-d tree over a point set's features, built once (the model's), matched against many
// scenes: for each query point (of `subset`, all when empty) the nearest indexed feature.
class FeatureIndex {
 public:
  explicit FeatureIndex(const PointSet& indexed);
  ~FeatureIndex();
  FeatureIndex(const FeatureIndex&) = delete;
  FeatureIndex& operator=(const FeatureIndex&) = delete;
  // (query index, indexed index) pairs, the k nearest per query point; `distances` (if
  // given) gets the feature distances.
  std::vector<Eigen::Vector2i> match(const PointSet& query, const std::vector<std::size_t>& subset, int k = 1,
                                     std::vector<double>* distances = nullptr) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// RANSAC over feature correspondences whose hypotheses are validated by the caller's score
// (paper 004 Sec. 3.2 step 2 with a stronger validation; docs/3d.md "Why our own RANSAC
// loop"). Built once per scene: the scene points, their correspondences (scene index ->
// model index) and, for each scene point, the scene points within neighbourhoodMm (the
// part's diameter): the 2nd and 3rd samples are drawn from the 1st one's neighbourhood, so
// all three tend to lie on the same object even among clutter. Each iteration: 3 samples,
// Open3D's edge-length checker (before any estimate), the rigid estimate (Umeyama, Open3D's
// point-to-point estimation), Open3D's distance checker, then score(T_scene_model). The
// best `keep` hypotheses at least 10 mm / 10 deg apart are returned, best first.
class CorrespondenceSampler {
 public:
  CorrespondenceSampler(const PointSet& scene, const std::vector<Eigen::Vector2i>& sceneToModel, double neighbourhoodMm);
  ~CorrespondenceSampler();
  CorrespondenceSampler(const CorrespondenceSampler&) = delete;
  CorrespondenceSampler& operator=(const CorrespondenceSampler&) = delete;

  struct Settings {
    int iterations = 20000;
    double distanceMm = 15;      // distance checker
    double edgeSimilarity = 0.8;  // edge-length checker
    int keep = 3;
    unsigned seed = 1;
    // 3: three correspondences (the paper's mu = 3). 2: two correspondences with their
    // normals (an oriented pair fixes a pose), checked by the edge-length ratio and the
    // normal angles (at most normalAngleDeg apart), estimated from the two points and a point
    // 10 mm along each normal: two right guesses are needed instead of three.
    int sampleSize = 2;
    double normalAngleDeg = 15;
  };
  struct Hypothesis {
    Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  // model -> scene
    double score = 0;
  };
  // active: per scene point, whether it may be sampled (points of found parts are not).
  std::vector<Hypothesis> run(const PointSet& model, const std::vector<char>& active, const Settings& s,
                              const std::function<double(const Eigen::Matrix4d&)>& score) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// For each source feature its nearest target feature (L2 in FPFH space): the putative
// correspondences RANSAC samples from, computed once per scene and reused by all n_R copies.
std::vector<Eigen::Vector2i> featureCorrespondences(const PointSet& source, const PointSet& target, bool mutualFilter);

struct Registration {
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();  // source -> target
  // IcpTarget::align only: J^T J of the last step's point-to-plane residuals, parameters
  // (rotation about `pivot` in rad, translation in mm) of a motion applied in the target frame.
  Eigen::Matrix<double, 6, 6> hessian = Eigen::Matrix<double, 6, 6>::Zero();
  double fitness = 0;   // Open3D's: source points with a target point within the distance / source points
  double rmseMm = 0;    // RMS of those correspondences
  std::size_t correspondences = 0;
};

// RANSAC over correspondences (paper 004 Sec. 3.2 step 2, [36]): samples 3, estimates a
// rigid transform, prunes it with the edge-length (similarity `edgeSimilarity`), distance
// (maxDistanceMm) and, when normalAngleDeg > 0 and both sets have normals, normal-angle
// checkers, validates the survivors by their inlier count.
Registration ransacOnCorrespondences(const PointSet& source, const PointSet& target, const std::vector<Eigen::Vector2i>& corres,
                                     double maxDistanceMm, double edgeSimilarity, int maxIterations, double confidence,
                                     double normalAngleDeg = 0);

// Point-to-plane ICP (paper 004 eq. 2): minimises sum ((T s - t) . n_t)^2 over pairs closer
// than maxDistanceMm; the target needs normals.
Registration icpPointToPlane(const PointSet& source, const PointSet& target, double maxDistanceMm, const Eigen::Matrix4d& init,
                             int maxIterations);
// Point-to-plane ICP (paper 004 eq. 2) against a fixed target (the model: exact normals, its
// k-d tree built once) with normal-compatible correspondences: a pair counts only if the
// source normal (turned by the current estimate) and the target normal differ by at most
// maxNormalAngleDeg. Near an edge the nearest model point may lie on the adjacent face,
// whose normal would push the part sideways (measured: up to 1.4 mm from the true pose with
// plain nearest neighbours); the check keeps such pairs out. Gauss-Newton on the linearised
// residual ((R s + t - q) . n_q), at most `iterations` steps, stops when a step moves less
// than 1 um / 1e-6 rad. fitness/rmse as Open3D's (share of source points paired, RMS of the
// point-to-point distance of the pairs).
class IcpTarget {
 public:
  explicit IcpTarget(const PointSet& target);  // needs normals
  ~IcpTarget();
  IcpTarget(const IcpTarget&) = delete;
  IcpTarget& operator=(const IcpTarget&) = delete;
  // source needs normals; returns source -> target.
  // minEigenShare > 0: each Gauss-Newton step moves only along the directions of J^T J
  // (rotation about `pivot` scaled to mm at the pairs' RMS distance from it) whose eigenvalue
  // is at least this share of the largest; the others stay where they are (a flat face says
  // nothing about the turn about its normal: an undamped step let noise turn a housing
  // 0.1 -> 3.9 deg about the view axis in 90 iterations). Zhang, Kaess, Singh, "On
  // degeneracy of optimization-based state estimation problems", ICRA 2016, Sec. IV.
  Registration align(const PointSet& source, double maxDistanceMm, double maxNormalAngleDeg, const Eigen::Matrix4d& init,
                     int iterations, const Eigen::Vector3d& pivot = Eigen::Vector3d::Zero(), double minEigenShare = 0) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

// Fitness and RMSE of `transform` without iterating.
Registration evaluate(const PointSet& source, const PointSet& target, double maxDistanceMm, const Eigen::Matrix4d& transform);

// The 6x6 information matrix of a registered pair (the pose graph's edge weight).
Eigen::Matrix<double, 6, 6> informationMatrix(const PointSet& source, const PointSet& target, double maxDistanceMm,
                                              const Eigen::Matrix4d& transform);

// Multiway registration (paper 004 Sec. 3.1, [32, 34]): node i's pose maps view i to the
// common frame; an edge (s, t) holds T_t_s (maps view s into view t) with its information;
// odometry edges (t = s + 1) are certain, loop closures uncertain (the optimiser's line
// process may prune them). Global Levenberg-Marquardt; node `reference` stays fixed.
struct PoseGraphEdge {
  int source = 0, target = 0;
  Eigen::Matrix4d transform = Eigen::Matrix4d::Identity();
  Eigen::Matrix<double, 6, 6> information = Eigen::Matrix<double, 6, 6>::Identity();
  bool uncertain = false;
};
struct PoseGraphResult {
  std::vector<Eigen::Matrix4d> nodes;
  std::vector<bool> edgeKept;  // per input edge: still in the graph after pruning
};
PoseGraphResult optimisePoseGraph(const std::vector<Eigen::Matrix4d>& nodes, const std::vector<PoseGraphEdge>& edges,
                                  double maxCorrespondenceMm, double edgePruneThreshold, int reference);

// Nearest neighbours in a fixed point set (a k-d tree).
class NearestIndex {
 public:
  explicit NearestIndex(const Points& points);
  ~NearestIndex();
  NearestIndex(const NearestIndex&) = delete;
  NearestIndex& operator=(const NearestIndex&) = delete;
  // Squared distance to the nearest point and its index; (inf, -1) for an empty set.
  std::pair<double, int> nearest(const Eigen::Vector3d& p) const;

 private:
  struct Impl;
  std::unique_ptr<Impl> impl_;
};

}  // namespace vgr::vision::cloud::backend
