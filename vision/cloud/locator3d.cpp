// Paper 004 Sec. 3.2 and 5 (docs/3d.md "Pipeline"): the current view P_a is aligned to the
// model P_r by FPFH features [35], RANSAC on their correspondences [36] and point-to-plane
// ICP (eq. 2), tried from n_R copies of the model turned by 2 pi / n_R, accepted by the
// fitness thresholds f_l / f_h; several parts per view by removing each found part's points
// and searching again.
//
// Where we differ from the paper, and why (measured in docs/3d.md "Recall and speed"):
//  - by default (clusterMm > 0) the scene is split into objects (DBSCAN after the floor is
//    removed) and each object of a part's size gets pose hypotheses by point-pair-feature
//    voting (ppf.hpp) instead of FPFH + RANSAC (which found no hypothesis within 15 mm /
//    15 deg of the truth on its misses), refined coarse to fine by ICP (eq. 2); a candidate
//    must also not reach below the removed floor. n_R copies are not needed there (the
//    rotation about each normal is voted). With clusterMm = 0, the former pipeline:
//  - the model's features are computed on what each of modelViews viewpoints sees of it, so
//    they describe the same partial surfaces a depth view shows (the whole model's FPFH
//    mixes in hidden faces: 1-4 % of scene points matched the right place, vs 5-30 %);
//  - RANSAC samples the 2nd and 3rd correspondence near the 1st and ranks hypotheses by how
//    well the depth image supports them, keeping several for ICP (Open3D's RANSAC keeps one,
//    ranked by overlap, which a big flat face wins);
//  - the fitness is measured against what the viewpoint should see (cloud_math.hpp).
// modelViews = 0 runs the paper's pipeline as written (Open3D's RANSAC on whole-model FPFH).
#include "vision/cloud/locator3d.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <optional>
#include <ctime>
#include <random>
#include <string_view>
#include <utility>

#include <Eigen/Eigenvalues>
#include <Eigen/Geometry>
#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "vision/cloud/cloud_math.hpp"
#include "vision/cloud/open3d_backend.hpp"
#include "vision/cloud/ppf.hpp"

namespace vgr::vision::cloud {
namespace {

using backend::PointSet;
using Points = backend::Points;

constexpr double kModelFineMm = 1.5;     // visibility model spacing
// Clusters (DBSCAN): a core point has this many neighbours; a cluster with fewer points is
// not searched (a part shows at least ~80 points at a 3 mm voxel from any side).
constexpr int kClusterMinPoints = 3;
constexpr int kClusterMinSize = 20;
constexpr double kClusterZScale = 0.25;
// Bin walls (sceneWalls): planes through the floor's normal holding more points of the voxel
// grid than the whole model has, at most this many, found by RANSAC on two points with this
// many samples and counted on a subsample of at most this many points; inliers within one voxel.
constexpr int kMaxWalls = 4;
constexpr int kWallIterations = 200;
constexpr std::size_t kWallSample = 2000;
constexpr double kWallMinPairMm = 20;
constexpr double kSceneNormalRadiusMm = 2.5;
// Coarse-to-fine refinement (cluster search): ICP pairs needed on the voxel grid, and the
// fitness after the coarse stages below which the fine stage is not run.
constexpr std::size_t kMinIcpPairs = 15;
// PPF's hypotheses are up to ~40 deg off; the voxel grid's few points near a part need pairs
// whose normals differ that much, or ICP runs away on the handful left (measured: housing
// scene 107, 4 pairs of 392 points at 30 deg).
constexpr double kCoarseNormalAngleDeg = 45;
// Measured on scenes 100-105 of each part: true poses had 0.56-1.0 after the coarse stages
// (0.97-1.0 at the end), 75 % of the others below 0.4. Gate: half of f_l (0.35 by default;
// never above retry_min_fitness's reach), and the floor check with 10 mm to spare.
constexpr double kCoarseGateShare = 0.5;
constexpr double kCoarseFloorMarginMm = 10;
// The refinement of the accepted candidate moves only along the eigen-directions of ICP's
// J^T J with at least this share of the largest eigenvalue (open3d_backend.hpp
// IcpTarget::align): measured on housing scene 123, the undamped 90-iteration ICP turned the
// pose 0.1 -> 3.9 deg about the view axis; with it 0.08 deg.
constexpr double kRefineMinEigenShare = 0.01;
// A candidate this good ends the fine stage at once (searchClusters). Of 143 true poses on
// bench scenes 100-149 / 300-349, 137 had >= 0.97; the 180 deg flip that won at f_h 0.94.
constexpr double kSureFitness = 0.97;
// alignToEdges: the measured edges' noise (px) that weighs the silhouette against ICP's prior.
constexpr double kEdgeSigmaPx = 0.5;
// PPF (ppf.hpp): F quantised in 12 deg steps and max(voxel, 4 % of the model's diameter)
// (Drost et al. 2010: 12 deg, 5 %), 30 alpha bins; every 2nd cluster point a reference.
constexpr double kPpfAngleStepDeg = 12;
constexpr int kPpfAlphaBins = 30;
constexpr double kPpfMaxNormalAngleDeg = 150;
constexpr int kPpfRefStep = 2;
constexpr double kPpfMaxBucketShare = 3.0;
constexpr std::size_t kPpfRanked = 12;
// The second round (searchClusters, when the first accepts nothing): the most voted of all
// references' merged peaks re-ranked by the depth image, and how many per cluster (not tried
// in the first round) go through both stages (the third pass took ranks 3-7 of the first
// round's 12: 5).
constexpr std::size_t kPpfRankedSecond = 24;
constexpr std::size_t kSecondRoundCount = 5;
// FPFH neighbours: Open3D's tutorial caps them at 100, which at a 3 mm voxel cuts a 30 mm
// radius to ~17 mm; 500 keeps the radius (measured: right matches 9 % -> 18 %).
constexpr int kFpfhMaxNeighbours = 500;
constexpr double kModelIcpMm = 1.0;      // ICP target spacing
constexpr double kNormalAngleDeg = 30;   // ICP pairs: normals at most this far apart
constexpr double kCropNormalRadiusMm = 3;  // normals of the measured points near a candidate
constexpr double kPaperEdgeSimilarity = 0.9;  // Open3D's tutorial value (the paper's pipeline)
constexpr double kContradictionWeight = 2;    // hypothesis score: matched - 2 x seen-through
// Evidence: a candidate counts only if the view should show at least this share of the
// fewest model points any viewpoint sees (the minimum over 64 directions: bracket 324,
// housing 321, lever 289 at 1.5 mm spacing). Points outside the image count as unseen, so a
// pose mostly outside the image, or one that shows the camera only a thin side, cannot win
// on a fitness that is a share of almost nothing.
constexpr double kMinViewShare = 0.5;
// A candidate whose silhouette ring (cloud_math.hpp Visibility::continuation) continues the
// measured surface at more than this share is not a part there (measured on 5 bracket scenes:
// the false poses 214-298 mm off had fitness 0.95-1.0; see docs/3d.md).
constexpr double kMaxContinuation = 0.5;
// A part must lie in the image: at most this share of its camera-facing points may project
// outside it (the view cannot confirm what it does not see).
constexpr double kMaxOutsideShare = 0.1;
// ... and at most this share may fall on pixels without data: the bin's walls, seen at
// grazing angles, are mostly invalid pixels, and a model laid across them matched the few
// valid ones (measured at 320 x 240: housing scene 2, a pose 264 mm off with fitness 0.99
// and 621 unknown of 918 points; true poses have 0-2 % unknown).
constexpr double kMaxUnknownShare = 0.25;

struct Candidate {
  Eigen::Matrix4d camFromModel = Eigen::Matrix4d::Identity();
  Visibility vis;
  double rmseMm = 0;
  int copy = 0;
  bool valid = false;
  double belowPlaneMm = 0;  // deepest model point beyond the removed plane (the floor)
  double coarseFitness = -1;  // the visibility check's fitness after the coarse ICP (cluster search)
  int cluster = -1;           // cluster search: the cluster it came from
  bool consistent(const Search3dParams& p) const { return valid && vis.contradiction <= p.maxContradiction; }
};

// Unit vectors spread evenly over the sphere (a Fibonacci lattice).
std::vector<Eigen::Vector3d> sphereDirections(int n) {
  std::vector<Eigen::Vector3d> out;
  for (int k = 0; k < n; ++k) {
    const double z = 1 - 2.0 * (k + 0.5) / n, r = std::sqrt(1 - z * z), phi = k * 2.399963229728653;
    out.emplace_back(r * std::cos(phi), r * std::sin(phi), z);
  }
  return out;
}

class Locator3dImpl final : public Locator3d {
 public:
  Locator3dImpl(const PlyCloud& model, const Pose& grasp, const Search3dParams& p)
      : params_(p), graspInModel_(toMatrix(grasp)), visibility_({}, {}, kModelFineMm) {
    Points pts, nrm;
    for (std::size_t i = 0; i < model.points.size(); ++i) {
      pts.emplace_back(model.points[i][0], model.points[i][1], model.points[i][2]);
      nrm.emplace_back(model.normals[i][0], model.normals[i][1], model.normals[i][2]);
    }
    const PointSet full(pts, nrm);
    backend::setThreads(p.threads);
    const double v = p.voxelMm;
    // The model at the matching voxel, its normals estimated as a view's are (outward).
    modelDown_ = full.voxelDown(v);
    modelDown_.reestimateNormals(2 * v, 30);
    modelFine_ = full.voxelDown(kModelFineMm);
    icpTarget_ = std::make_unique<backend::IcpTarget>(full.voxelDown(kModelIcpMm));
    Eigen::Vector3d c = Eigen::Vector3d::Zero();
    for (const auto& q : modelFine_.points()) c += q;
    centroid_ = c / static_cast<double>(modelFine_.size());
    for (const auto& q : modelFine_.points()) radius_ = std::max(radius_, (q - centroid_).norm());
    visibility_ = VisibilityCheck(modelFine_.points(), modelFine_.normals(), kModelFineMm);
    {
      std::vector<std::size_t> counts;
      for (const auto& d : sphereDirections(64))
        counts.push_back(visibleFrom(modelFine_.points(), modelFine_.normals(), d, kModelFineMm, p.visibleMaxAngleDeg).size());
      minSeen_ = static_cast<int>(std::lround(kMinViewShare * static_cast<double>(*std::min_element(counts.begin(), counts.end()))));
    }
    if (p.clusterMm > 0) {
      // the cluster search needs no FPFH (ppf_ below)
    } else if (p.modelViews > 0) {
      // FPFH of what each viewpoint sees: the views' points pooled, each remembering which
      // model point it is.
      std::vector<PointSet> views;
      Points poolPoints;
      for (const auto& d : sphereDirections(p.modelViews)) {
        const auto idx = visibleFrom(modelDown_.points(), modelDown_.normals(), d, v, p.visibleMaxAngleDeg);
        if (idx.size() < 10) continue;
        PointSet view = modelDown_.select(idx);
        view.estimateNormals(2 * v, 30, view.points().front() - 1e4 * d);
        view.computeFpfh(p.featureRadiusMm, kFpfhMaxNeighbours);
        for (std::size_t i : idx) {
          poolOwner_.push_back(static_cast<int>(i));
          poolPoints.push_back(modelDown_.points()[i]);
        }
        views.push_back(std::move(view));
      }
      PointSet pool(std::move(poolPoints));
      pool.setFeaturesFrom(views);
      featureIndex_ = std::make_unique<backend::FeatureIndex>(pool);
    } else {
      modelDown_.computeFpfh(p.featureRadiusMm, 100);  // paper 004: FPFH of the model
    }
    if (p.clusterMm > 0) {
      double diameter = 0;
      for (const auto& a : modelDown_.points())
        for (const auto& b : modelDown_.points()) diameter = std::max(diameter, (a - b).norm());
      diameter_ = diameter;
      // The model's exact normals on its voxel grid (not averaged across its edges), as the
      // scene's come from its full-resolution points (locate()).
      PointSet exact = full.voxelDown(v);
      exact.normalsFromNearest(full);
      ppf_ = std::make_unique<PpfModel>(exact.points(), exact.normals(), std::max(v, 0.04 * diameter), kPpfAngleStepDeg,
                                        kPpfAlphaBins, kPpfMaxNormalAngleDeg, kPpfMaxBucketShare);
    }
    // Paper 004 Sec. 3.2: "the acquired point cloud was compared with n_R different point
    // clouds, obtained by rotating the reconstructed model by an angle 2 pi / n_R" (about the
    // model's z axis through its centroid).
    for (int k = 0; k < p.nRotations; ++k) {
      Eigen::Matrix4d r = Eigen::Matrix4d::Identity();
      r.topLeftCorner<3, 3>() = Eigen::AngleAxisd(2 * M_PI * k / p.nRotations, Eigen::Vector3d::UnitZ()).toRotationMatrix();
      r.topRightCorner<3, 1>() = centroid_ - r.topLeftCorner<3, 3>() * centroid_;
      copyRotations_.push_back(r);
      copies_.push_back(modelDown_.transformed(r));
    }
  }

  const Search3dParams& params() const override { return params_; }

  Result<Locate3dResult> locate(const cv::Mat& depth, const DepthIntrinsics& k) override {
    if (depth.empty() || depth.type() != CV_32FC1)
      return fail(Status::BadArgument, "3D locate: the depth image must be CV_32FC1 z in mm (0 = no data)");
    if (depth.cols != k.width || depth.rows != k.height)
      return fail(Status::BadArgument, fmt::format("3D locate: the image is {}x{} px, the intrinsics are for {}x{}", depth.cols,
                                                   depth.rows, k.width, k.height));
    if (!(k.fx > 0) || !(k.fy > 0)) return fail(Status::BadArgument, "3D locate: focal lengths must be > 0 px");
    if (cv::countNonZero(depth > 0) == 0) return fail(Status::BadArgument, "3D locate: no valid depth pixel");
    backend::setThreads(params_.threads);
    backend::seedRandom(params_.seed);

    Locate3dResult out;
    const double v = params_.voxelMm;
    // The current view P_a in the camera frame, without the table / bin floor.
    stage("start");
    Points scene = backProject(depth, k, params_.roi);
    claimed_ = cv::Mat::zeros(depth.size(), CV_8UC1);
    plane_.reset();
    if (params_.removePlane) removeDominantPlane(scene, depth, k);
    PointSet all(std::move(scene));
    stage("back-projection + plane");
    PointSet sceneDown = all.voxelDown(v);
    out.scenePoints = static_cast<int>(sceneDown.size());
    if (sceneDown.size() < 30) {
      out.reason = fmt::format("{} points left after the ROI and plane removal", sceneDown.size());
      return out;
    }
    std::vector<std::vector<std::size_t>> clusters;
    if (ppf_) {
      stage("voxel");
      clusters = sceneClusters(sceneDown, sceneWalls(sceneDown));
      stage("clusters");
      // PPF needs normals true to each face: from the sensor's full-resolution points, for
      // the searched clusters' points only (a k-d tree over all of them cost ~80 ms); the
      // other points face the camera (ICP's normal check keeps them out of its pairs).
      Points normals;
      normals.reserve(sceneDown.size());
      for (const auto& p : sceneDown.points()) normals.push_back(-p.normalized());
      std::vector<std::size_t> inClusters;
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e18), hi = -lo;
      std::vector<std::pair<Eigen::Vector3d, Eigen::Vector3d>> boxes;
      for (const auto& c : clusters) {
        lo = Eigen::Vector3d::Constant(1e18), hi = -lo;
        for (std::size_t i : c) lo = lo.cwiseMin(sceneDown.points()[i]), hi = hi.cwiseMax(sceneDown.points()[i]);
        boxes.emplace_back(lo.array() - v, hi.array() + v);
        inClusters.insert(inClusters.end(), c.begin(), c.end());
      }
      Points dense;
      for (const auto& p : all.points())
        for (const auto& b : boxes)
          if ((p.array() >= b.first.array()).all() && (p.array() <= b.second.array()).all()) {
            dense.push_back(p);
            break;
          }
      PointSet sub = sceneDown.select(inClusters);
      sub.estimateNormalsFrom(PointSet(std::move(dense)), kSceneNormalRadiusMm, Eigen::Vector3d::Zero());
      for (std::size_t j = 0; j < inClusters.size(); ++j) normals[inClusters[j]] = sub.normals()[j];
      sceneDown.setNormals(std::move(normals));
    } else {
      sceneDown.estimateNormals(2 * v, 30, Eigen::Vector3d::Zero());  // the camera is at the origin
      sceneDown.computeFpfh(params_.featureRadiusMm, kFpfhMaxNeighbours);
    }
    Points remaining = all.points();

    // Correspondences: each scene point's nearest model feature (paper 004 Sec. 3.2 step 2).
    std::vector<Eigen::Vector2i> sceneToModel;
    std::unique_ptr<backend::CorrespondenceSampler> sampler;
    if (ppf_) {
      stage("normals");
    } else if (featureIndex_) {
      for (const auto& m : featureIndex_->match(sceneDown, {}, 1))
        sceneToModel.emplace_back(m[0], poolOwner_[static_cast<std::size_t>(m[1])]);
      sampler = std::make_unique<backend::CorrespondenceSampler>(sceneDown, sceneToModel, 2 * radius_);
    }
    std::vector<char> active(sceneDown.size(), 1);

    Candidate bestOther;
    while (static_cast<int>(out.parts.size()) < params_.maxParts) {
      Candidate best;
      if (ppf_) {
        sceneDown_ = &sceneDown;
      activeDown_ = &active;
      best = searchClusters(clusters, sceneDown, active, remaining, depth, k, out.candidates);
      } else {
        for (int c = 0; c < params_.nRotations; ++c) {
          for (auto& cand : hypotheses(c, sceneDown, sampler.get(), active, depth, k, static_cast<int>(out.parts.size()))) {
            refineCandidate(cand, remaining, depth, k);
            ++out.candidates;
            traceCandidate(cand);
            if (cand.valid && (!best.valid || better(cand, best))) best = cand;
          }
          if (best.consistent(params_) && best.vis.fitness >= params_.fHigh) break;  // paper: stop above f_h
        }
      }
      if (!best.valid) break;
      bool accept = best.consistent(params_) && best.vis.fitness >= params_.fHigh;
      bool refined = false;
      if (accept && ppf_) {
        // Cluster search: the accepted candidate gets the longer, tighter ICP too (paper 004
        // eq. 2 at 0.6 icp_distance_mm, then the boundary alignment), kept when it still
        // passes at f_h. Measured on the poses with the largest errors: bracket scenes 127 /
        // 128 1.98 / 1.77 deg -> 1.52 / 1.49 deg; housing 128 (hypotheses 8) 2.43 -> 0.09 deg.
        const Candidate r = refine(best, remaining, depth, k);
        if (r.valid && r.consistent(params_) && r.vis.fitness >= params_.fHigh) best = r;
      }
      if (!accept && best.consistent(params_) && best.vis.fitness >= params_.fLow) {
        // Between f_l and f_h: refine (longer, tighter ICP) and check again.
        best = refine(best, remaining, depth, k);
        refined = true;
        accept = best.consistent(params_) && best.vis.fitness >= params_.fLow;
      }
      if (!accept) {
        if (!bestOther.valid || better(best, bestOther)) bestOther = best;
        break;
      }
      Part3d part;
      part.pose = toPose(best.camFromModel);
      part.grasp = toPose(best.camFromModel * graspInModel_);
      part.fitness = best.vis.fitness;
      part.contradiction = best.vis.contradiction;
      part.rmseMm = best.rmseMm;
      part.score = best.vis.fitness;
      part.rotationCopy = best.copy;
      part.refined = refined;
      out.parts.push_back(part);
      if (static_cast<int>(out.parts.size()) >= params_.maxParts) break;
      removeExplained(best.camFromModel, sceneDown, active, remaining, depth, k);
      if (std::count(active.begin(), active.end(), 1) < 30) break;
    }
    sceneDown_ = nullptr;
    activeDown_ = nullptr;
    stage("search");
    std::sort(out.parts.begin(), out.parts.end(), [](const Part3d& a, const Part3d& b) { return a.score > b.score; });
    if (!out.parts.empty()) {
      out.outcome = Outcome3d::Found;
    } else if (bestOther.consistent(params_) && bestOther.vis.fitness >= params_.retryMinFitness) {
      out.outcome = Outcome3d::RetryFromNewViewpoint;
      out.reason = fmt::format("best candidate fits the view but shows only {:.0f} % of what this viewpoint should see (f_l {:.0f} %)",
                               100 * bestOther.vis.fitness, 100 * params_.fLow);
    } else {
      out.outcome = Outcome3d::NotFound;
      out.reason = bestOther.valid ? fmt::format("no candidate consistent with the view (best: fitness {:.2f}, sees through {:.0f} %)",
                                                 bestOther.vis.fitness, 100 * bestOther.vis.contradiction)
                                   : std::string("no candidate");
    }
    out.bestOtherFitness = bestOther.valid ? bestOther.vis.fitness : 0;
    return out;
  }

 private:
  // VGR_CLOUD_TRACE: CPU ms since the last stage() call, on stderr.
  static void stage(const char* what) {
    static const bool on = std::getenv("VGR_CLOUD_TRACE") != nullptr;
    if (!on) return;
    static double last = 0;
    timespec t{};
    clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
    const double now = t.tv_sec * 1e3 + t.tv_nsec / 1e6;
    if (what[0] != '-' && std::string_view(what) != "start") std::fprintf(stderr, "  [%s: %.0f ms cpu]\n", what, now - last);
    last = now;
  }

  // The scene's Euclidean clusters (DBSCAN, radius clusterMm) after plane removal: after the
  // bin floor is gone, each part and each clutter object is its own cluster. Returns the
  // clusters whose extent could be (part of) one part (bounding-box diagonal at most the
  // model's diameter + 2 clusterMm), each a list of sceneDown indices; biggest first.
  // wall: sceneDown points left out (sceneWalls), may be empty.
  std::vector<std::vector<std::size_t>> sceneClusters(const PointSet& sceneDown, const std::vector<char>& wall) const {
    // z compressed: a part's faces at different heights are often separated by the invalid
    // pixels of its steep walls (measured: the bracket's flange and base plate 24 mm apart
    // in z fell into separate clusters at 8 and 15 mm); objects side by side are not.
    Points squashed;
    std::vector<std::size_t> owner;
    for (std::size_t i = 0; i < sceneDown.size(); ++i) {
      if (!wall.empty() && wall[i]) continue;
      const auto& p = sceneDown.points()[i];
      squashed.emplace_back(p.x(), p.y(), kClusterZScale * p.z());
      owner.push_back(i);
    }
    const auto labels = PointSet(std::move(squashed)).clusters(params_.clusterMm, kClusterMinPoints);
    int n = 0;
    for (int l : labels) n = std::max(n, l + 1);
    std::vector<std::vector<std::size_t>> all(static_cast<std::size_t>(n));
    for (std::size_t i = 0; i < labels.size(); ++i)
      if (labels[i] >= 0) all[static_cast<std::size_t>(labels[i])].push_back(owner[i]);
    std::vector<std::vector<std::size_t>> out;
    const auto* truth = traceTruth();
    std::unique_ptr<backend::NearestIndex> truthIndex;
    if (truth) {
      Points placed;
      for (const auto& p : modelFine_.points()) placed.push_back((*truth * p.homogeneous()).head<3>());
      truthIndex = std::make_unique<backend::NearestIndex>(placed);
    }
    for (auto& c : all) {
      Eigen::Vector3d lo = Eigen::Vector3d::Constant(1e18), hi = -lo;
      for (std::size_t i : c) lo = lo.cwiseMin(sceneDown.points()[i]), hi = hi.cwiseMax(sceneDown.points()[i]);
      const double diag = (hi - lo).norm();
      // Plausible size: no more points than the whole model at this voxel, and no two points
      // farther apart than the model's diameter (+ a voxel of noise each side).
      bool plausible = static_cast<int>(c.size()) >= kClusterMinSize && c.size() <= modelDown_.size();
      double diameter = 0;
      for (std::size_t a = 0; plausible && a < c.size(); ++a)
        for (std::size_t b = a + 1; b < c.size(); ++b)
          diameter = std::max(diameter, (sceneDown.points()[c[a]] - sceneDown.points()[c[b]]).squaredNorm());
      diameter = std::sqrt(diameter);
      plausible = plausible && diameter <= diameter_ + 2 * params_.voxelMm;
      if (truthIndex) {
        int onPart = 0;
        for (std::size_t i : c) onPart += truthIndex->nearest(sceneDown.points()[i]).first <= 9.0;
        if (onPart > 0 || plausible)
          std::fprintf(stderr, "  cluster %zu pts diag %.0f (diameter %.0f) mm %s, %d on the true part\n", c.size(), diag, diameter, plausible ? "plausible" : "skipped", onPart);
      }
      if (plausible) {
        out.push_back(std::move(c));
      }
    }
    std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.size() > b.size(); });
    return out;
  }

  // The bin's walls: up to kMaxWalls planes through the removed floor's normal (a vertical
  // plane is fixed by two points), each holding more voxel-grid points than the whole model
  // has (no part's face can), found by RANSAC one after the other; their points within a
  // voxel are left out of the clusters (a part touching a wall formed one cluster with all
  // the walls, larger than a part and never searched: lever bench scenes 142 / 147). The
  // points stay in the scene for ICP and the visibility check. Empty when no floor was removed.
  std::vector<char> sceneWalls(const PointSet& sceneDown) const {
    std::vector<char> wall;
    if (!plane_ || sceneDown.size() < modelDown_.size()) return wall;
    wall.assign(sceneDown.size(), 0);
    const Eigen::Vector3d up = plane_->head<3>().normalized();
    const auto& pts = sceneDown.points();
    const double tol = params_.voxelMm;
    std::mt19937 rng(params_.seed);
    for (int w = 0; w < kMaxWalls; ++w) {
      std::vector<std::size_t> left;
      for (std::size_t i = 0; i < pts.size(); ++i)
        if (!wall[i]) left.push_back(i);
      if (left.size() < modelDown_.size()) break;
      std::vector<std::size_t> sample = left;
      if (sample.size() > kWallSample) {
        std::shuffle(sample.begin(), sample.end(), rng);
        sample.resize(kWallSample);
      }
      std::uniform_int_distribution<std::size_t> pick(0, sample.size() - 1);
      Eigen::Vector3d bestN = Eigen::Vector3d::Zero();
      double bestD = 0;
      std::size_t bestCount = 0;
      for (int it = 0; it < kWallIterations; ++it) {
        const Eigen::Vector3d& a = pts[sample[pick(rng)]];
        const Eigen::Vector3d& b = pts[sample[pick(rng)]];
        Eigen::Vector3d n = (b - a).cross(up);
        if (n.norm() < kWallMinPairMm) continue;
        n.normalize();
        const double d = -n.dot(a);
        std::size_t count = 0;
        for (std::size_t i : sample) count += std::abs(n.dot(pts[i]) + d) <= tol;
        if (count > bestCount) bestCount = count, bestN = n, bestD = d;
      }
      if (bestCount == 0) break;
      std::vector<std::size_t> in;
      for (std::size_t i : left)
        if (std::abs(bestN.dot(pts[i]) + bestD) <= tol) in.push_back(i);
      if (std::getenv("VGR_CLOUD_TRACE")) std::fprintf(stderr, "  wall plane %d: %zu points (needs > %zu)\n", w, in.size(), modelDown_.size());
      if (in.size() <= modelDown_.size()) break;
      for (std::size_t i : in) wall[i] = 1;
    }
    return wall;
  }

  // Registers the model against each cluster on its own (paper 004 Sec. 3.2, with step 2's
  // FPFH + RANSAC replaced by PPF voting, ppf.hpp; docs/3d.md "Recall and speed"): the
  // cluster's reference-point peaks, merged and ranked, the best hypothesesPerCopy through
  // the coarse stage (ICP, eq. 2, on the voxel grid + gate); then over all clusters the fine
  // stage (ICP, eq. 2, on the sensor's points + every check), best coarse fit first, until
  // one is accepted at f_h (paper 004 Sec. 5). The best candidate seen.
  Candidate searchClusters(const std::vector<std::vector<std::size_t>>& clusters, const PointSet& sceneDown,
                           const std::vector<char>& active, const Points& remaining, const cv::Mat& depth, const DepthIntrinsics& k,
                           int& candidates) {
    Candidate best;
    std::vector<Candidate> coarse;  // hypotheses that passed the coarse stage
    struct Hyp {
      Eigen::Matrix4d t;
      double votes, score;
    };
    // Each reference point's PPF peak merged into `hyps` when within 10 mm / 10 deg of one
    // there (its votes added), else appended; then sorted by votes.
    const auto mergePeaks = [](const std::vector<PpfModel::Vote>& votes, std::vector<Hyp>& hyps) {
      for (const auto& vote : votes) {
        bool merged = false;
        for (auto& h : hyps)
          if (translationErrorMm(h.t, vote.sceneFromModel) < 10 && rotationErrorDeg(h.t, vote.sceneFromModel) < 10) {
            h.votes += vote.votes;
            merged = true;
            break;
          }
        if (!merged) hyps.push_back({vote.sceneFromModel, static_cast<double>(vote.votes), 0});
      }
      std::stable_sort(hyps.begin(), hyps.end(), [](const Hyp& a, const Hyp& b) { return a.votes > b.votes; });
    };
    // The `n` most voted re-ranked by how well the depth image supports them (quickScore).
    const auto rankTop = [&](const std::vector<Hyp>& hyps, std::size_t n) {
      std::vector<Hyp> top(hyps.begin(), hyps.begin() + static_cast<std::ptrdiff_t>(std::min(n, hyps.size())));
      for (auto& h : top) h.score = quickScore(0, h.t, depth, k);
      std::stable_sort(top.begin(), top.end(), [](const Hyp& a, const Hyp& b) { return a.score > b.score; });
      return top;
    };
    const auto traceRank = [](const char* what, std::size_t ci, const std::vector<Hyp>& hyps) {
      const auto* truth = traceTruth();
      if (!truth) return;
      int rank = -1;
      for (std::size_t i = 0; i < hyps.size() && rank < 0; ++i)
        if (translationErrorMm(hyps[i].t, *truth) < 15 && rotationErrorDeg(hyps[i].t, *truth) < 15) rank = static_cast<int>(i);
      std::fprintf(stderr, " cluster %zu: %zu %s, first near the truth at rank %d\n", ci, hyps.size(), what, rank);
    };
    // A hypothesis of cluster ci through the coarse stages: kept in `out` when it passes their
    // gate, else counted and traced as a tried candidate.
    const auto tryCoarse = [&](const Eigen::Matrix4d& t, std::size_t ci, std::vector<Candidate>& out) {
      Candidate cand;
      cand.camFromModel = t;
      cand.cluster = static_cast<int>(ci);
      if (coarseRefine(cand, depth, k)) {
        out.push_back(cand);
      } else {
        ++candidates;
        traceCandidate(cand);
      }
    };
    std::vector<std::vector<Hyp>> merged(clusters.size());  // per cluster, every peak merged, most voted first
    std::vector<std::vector<Hyp>> ranked(clusters.size());  // per cluster, the first round's, best first
    std::vector<PointSet> searched(clusters.size());        // per cluster, its active points with normals
    for (std::size_t ci = 0; ci < clusters.size(); ++ci) {
      std::vector<std::size_t> idx;
      for (std::size_t i : clusters[ci])
        if (active[i]) idx.push_back(i);
      if (static_cast<int>(idx.size()) < kClusterMinSize) continue;
      searched[ci] = sceneDown.select(idx);
      const PointSet& cl = searched[ci];
      // Hypotheses: each reference point's PPF peak (ppf.hpp), every kPpfRefStep-th cluster
      // point a reference, merged, the kPpfRanked most voted re-ranked, the best
      // hypothesesPerCopy refined.
      const auto votes = ppf_->match(cl.points(), cl.normals(), kPpfRefStep);
      if (const auto* truth = traceTruth()) {
        int near = 0, maxVotes = 0, maxNear = 0;
        for (const auto& vote : votes) {
          maxVotes = std::max(maxVotes, vote.votes);
          if (translationErrorMm(vote.sceneFromModel, *truth) < 15 && rotationErrorDeg(vote.sceneFromModel, *truth) < 15)
            ++near, maxNear = std::max(maxNear, vote.votes);
        }
        std::fprintf(stderr, " cluster %zu: %zu reference peaks, %d near the truth (most votes %d, near the truth %d)\n", ci, votes.size(), near, maxVotes, maxNear);
      }
      mergePeaks(votes, merged[ci]);
      traceRank("merged by votes", ci, merged[ci]);
      ranked[ci] = rankTop(merged[ci], kPpfRanked);
      traceRank("re-ranked", ci, ranked[ci]);
      const auto& hyps = ranked[ci];
      for (std::size_t i = 0; i < hyps.size() && static_cast<int>(i) < params_.hypothesesPerCopy; ++i)
        tryCoarse(hyps[i].t, ci, coarse);
    }
    stage("  ppf + coarse ICP");
    // The fine stage, best coarse fit first (over all clusters), until one is accepted at f_h.
    std::stable_sort(coarse.begin(), coarse.end(), [](const Candidate& a, const Candidate& b) { return a.coarseFitness > b.coarseFitness; });
    // Once one is over f_h but below kSureFitness, the other candidates of its cluster are
    // refined too and the best fit wins: the first over f_h was a bracket turned 180 deg on
    // itself (bench scene 334: fitness 0.94, 29 mm off) while the true pose (rank 3 in that
    // cluster) fits 1.00.
    int acceptedCluster = -1;
    for (auto& cand : coarse) {
      if (acceptedCluster >= 0 && cand.cluster != acceptedCluster) continue;
      fineRefine(cand, remaining, depth, k);
      ++candidates;
      traceCandidate(cand);
      if (cand.valid && (!best.valid || better(cand, best))) best = cand;
      if (best.consistent(params_) && best.vis.fitness >= kSureFitness) break;
      if (acceptedCluster < 0 && best.consistent(params_) && best.vis.fitness >= params_.fHigh) acceptedCluster = best.cluster;
    }
    stage("  fine");
    if (best.consistent(params_) && best.vis.fitness >= params_.fHigh) return best;
    // Second round, only when nothing reached f_h: per cluster, the other half of its points
    // as PPF references too (the first round's references shifted by one), their peaks merged
    // with the first round's, the kPpfRankedSecond most voted re-ranked, and the best
    // kSecondRoundCount of them not tried in the first round through both stages; the best
    // consistent fit wins (not the first over f_h). docs/3d.md "Recall (issue 13, fourth
    // pass)": the misses had a single near-truth peak among every 2nd reference (bracket 120,
    // housing 319) or their near-truth hypothesis at vote rank 13-22 (bracket 326, housing
    // 336). Re-ranking 24 in the first round made a bracket turned 180 deg on itself (fitness
    // 0.98) win on scene 146: the first round keeps its 12.
    std::vector<Candidate> more;
    for (std::size_t ci = 0; ci < ranked.size(); ++ci) {
      if (searched[ci].size() == 0) continue;
      const PointSet& cl = searched[ci];
      Points shiftedP(cl.points().begin() + 1, cl.points().end()), shiftedN(cl.normals().begin() + 1, cl.normals().end());
      shiftedP.push_back(cl.points().front());
      shiftedN.push_back(cl.normals().front());
      mergePeaks(ppf_->match(shiftedP, shiftedN, kPpfRefStep), merged[ci]);
      const auto second = rankTop(merged[ci], kPpfRankedSecond);
      traceRank("re-ranked (second round)", ci, second);
      const std::size_t tried = std::min(ranked[ci].size(), static_cast<std::size_t>(params_.hypothesesPerCopy));
      std::size_t taken = 0;
      for (const auto& h : second) {
        if (taken >= kSecondRoundCount) break;
        bool done = false;
        for (std::size_t i = 0; i < tried && !done; ++i)
          done = translationErrorMm(h.t, ranked[ci][i].t) < 10 && rotationErrorDeg(h.t, ranked[ci][i].t) < 10;
        if (done) continue;
        ++taken;
        tryCoarse(h.t, ci, more);
      }
    }
    for (auto& cand : more) {
      fineRefine(cand, remaining, depth, k);
      ++candidates;
      traceCandidate(cand);
      if (cand.valid && (!best.valid || better(cand, best))) best = cand;
    }
    stage("  second round");
    return best;
  }

  // VGR_CLOUD_TRACE with VGR_CLOUD_TRUTH: the error of a refinement stage's pose, and the
  // rotation error's axis x angle (deg) and the translation error in the camera frame.
  static void traceErr(const char* tag, const Eigen::Matrix4d& m) {
    const auto* truth = traceTruth();
    if (!truth) return;
    const Eigen::Matrix3d d = m.topLeftCorner<3, 3>() * truth->topLeftCorner<3, 3>().transpose();
    const Eigen::AngleAxisd aa(d);
    const Eigen::Vector3d ax = aa.axis() * aa.angle() * 180 / M_PI;
    std::fprintf(stderr, "  XERR %s: %.2f mm %.2f deg  rot cam (%.2f %.2f %.2f) dt (%.2f %.2f %.2f)\n", tag, translationErrorMm(m, *truth),
                 rotationErrorDeg(m, *truth), ax.x(), ax.y(), ax.z(), m(0, 3) - (*truth)(0, 3), m(1, 3) - (*truth)(1, 3), m(2, 3) - (*truth)(2, 3));
  }
  // VGR_CLOUD_TRACE with VGR_CLOUD_TRUTH: the true pose of one part, for the trace; else null.
  static const Eigen::Matrix4d* traceTruth() {
    if (!std::getenv("VGR_CLOUD_TRACE")) return nullptr;
    static thread_local Eigen::Matrix4d truth;
    const char* t = std::getenv("VGR_CLOUD_TRUTH");
    Pose p;
    if (!t || std::sscanf(t, "%lf %lf %lf %lf %lf %lf %lf", &p.x, &p.y, &p.z, &p.qw, &p.qx, &p.qy, &p.qz) != 7) return nullptr;
    truth = toMatrix(p);
    return &truth;
  }

  // Debugging aid: VGR_CLOUD_TRACE prints every candidate (with its error when
  // VGR_CLOUD_TRUTH holds "x y z qw qx qy qz" of one true part) on stderr.
  static void traceCandidate(const Candidate& c) {
    static const bool on = std::getenv("VGR_CLOUD_TRACE") != nullptr;
    if (!on) return;
    std::string err;
    if (const char* t = std::getenv("VGR_CLOUD_TRUTH")) {
      Pose p;
      if (std::sscanf(t, "%lf %lf %lf %lf %lf %lf %lf", &p.x, &p.y, &p.z, &p.qw, &p.qx, &p.qy, &p.qz) == 7)
        err = fmt::format(" err {:.2f} mm {:.2f} deg", translationErrorMm(c.camFromModel, toMatrix(p)), rotationErrorDeg(c.camFromModel, toMatrix(p)));
    }
    std::fprintf(stderr, "  cand coarse %.2f below %.1f valid %d out %d cont %.2f f %.3f c %.3f m %d o %d x %d u %d%s\n", c.coarseFitness, c.belowPlaneMm, c.valid, c.vis.outside, c.vis.continuation, c.vis.fitness, c.vis.contradiction,
                 c.vis.matched, c.vis.occluded, c.vis.contradicted, c.vis.unknown, err.c_str());
    const Pose cp = toPose(c.camFromModel);
    std::fprintf(stderr, "    at %.1f %.1f %.1f q %.3f %.3f %.3f %.3f\n", cp.x, cp.y, cp.z, cp.qw, cp.qx, cp.qy, cp.qz);
  }

  // Consistent candidates first, then by fitness.
  bool better(const Candidate& a, const Candidate& b) const {
    const bool ca = a.consistent(params_), cb = b.consistent(params_);
    if (ca != cb) return ca;
    return a.vis.fitness > b.vis.fitness;
  }

  // Removes the dominant plane (table, bin floor) and everything beyond it, when it holds at
  // least planeMinShare of the points (RANSAC on a sparse sample, then every point tested),
  // and marks its pixels kPixelPlane in claimed_.
  void removeDominantPlane(Points& pts, const cv::Mat& depth, const DepthIntrinsics& k) {
    if (pts.size() < 100) return;
    Points sample;
    const std::size_t step = std::max<std::size_t>(1, pts.size() / 20000);
    for (std::size_t i = 0; i < pts.size(); i += step) sample.push_back(pts[i]);
    const auto plane = PointSet(std::move(sample)).segmentPlane(params_.planeDistanceMm, 200);
    const std::size_t sampled = (pts.size() + step - 1) / step;
    if (plane.inliers.size() < params_.planeMinShare * static_cast<double>(sampled)) return;
    Eigen::Vector4d c = plane.coefficients;
    if (c[3] < 0) c = -c;  // the camera (origin) on the positive side
    plane_ = c;
    std::erase_if(pts, [&](const Eigen::Vector3d& p) { return c.head<3>().dot(p) + c[3] < params_.planeDistanceMm; });
    for (int v = 0; v < depth.rows; ++v) {
      const float* zr = depth.ptr<float>(v);
      std::uint8_t* mr = claimed_.ptr<std::uint8_t>(v);
      for (int u = 0; u < depth.cols; ++u) {
        const double z = zr[u];
        if (!(z > 0)) continue;
        const Eigen::Vector3d p((u - k.cx) * z / k.fx, (v - k.cy) * z / k.fy, z);
        if (c.head<3>().dot(p) + c[3] < params_.planeDistanceMm) mr[u] = kPixelPlane;
      }
    }
  }

  // How well the depth image supports copy `copy` placed by t (copy -> camera): the model
  // points facing the camera whose pixel shows their depth, minus twice those the sensor
  // sees through. Self-hidden points fall behind the measured surface: neutral.
  double quickScore(int copy, const Eigen::Matrix4d& t, const cv::Mat& depth, const DepthIntrinsics& k) const {
    const auto& pts = copies_[static_cast<std::size_t>(copy)].points();
    const auto& nrm = copies_[static_cast<std::size_t>(copy)].normals();
    const Eigen::Matrix3d r = t.topLeftCorner<3, 3>();
    const Eigen::Vector3d tr = t.topRightCorner<3, 1>();
    const double cosMin = std::cos(params_.visibleMaxAngleDeg * M_PI / 180.0), tol = params_.fitnessDistanceMm;
    int matched = 0, through = 0, hidden = 0;
    for (std::size_t i = 0; i < pts.size(); ++i) {
      const Eigen::Vector3d p = r * pts[i] + tr;
      if (p.z() <= 1 || -(r * nrm[i]).dot(p) < cosMin * p.norm()) continue;
      const int u = static_cast<int>(std::lround(k.fx * p.x() / p.z() + k.cx)), vv = static_cast<int>(std::lround(k.fy * p.y() / p.z() + k.cy));
      if (u < 0 || vv < 0 || u >= depth.cols || vv >= depth.rows || claimed_.at<std::uint8_t>(vv, u) == kPixelClaimed) continue;
      const double d = depth.at<float>(vv, u);
      if (!(d > 0)) continue;
      if (std::abs(d - p.z()) <= tol) matched += claimed_.at<std::uint8_t>(vv, u) == kPixelFree;
      else if (d > p.z() + tol) ++through;
      else ++hidden;
    }
    return matched - kContradictionWeight * through - hidden;
  }

  // RANSAC hypotheses for copy `copy`, as candidates (camFromModel, not yet refined).
  std::vector<Candidate> hypotheses(int copy, const PointSet& sceneDown, const backend::CorrespondenceSampler* sampler,
                                    const std::vector<char>& active, const cv::Mat& depth, const DepthIntrinsics& k, int round) {
    std::vector<Candidate> out;
    const Eigen::Matrix4d& rot = copyRotations_[static_cast<std::size_t>(copy)];
    if (sampler) {
      backend::CorrespondenceSampler::Settings s;
      s.iterations = params_.ransacIterations;
      s.distanceMm = params_.ransacDistanceMm;
      s.edgeSimilarity = params_.edgeSimilarity;
      s.keep = params_.hypothesesPerCopy;
      s.sampleSize = 3;  // the paper's mu = 3
      s.seed = params_.seed * 7919u + static_cast<unsigned>(copy) * 104729u + static_cast<unsigned>(round) * 1299709u;
      const char* truthText = std::getenv("VGR_CLOUD_TRACE") ? std::getenv("VGR_CLOUD_TRUTH") : nullptr;
      Eigen::Matrix4d truth = Eigen::Matrix4d::Identity();
      bool haveTruth = false;
      if (truthText) {
        Pose p;
        haveTruth = std::sscanf(truthText, "%lf %lf %lf %lf %lf %lf %lf", &p.x, &p.y, &p.z, &p.qw, &p.qx, &p.qy, &p.qz) == 7;
        truth = toMatrix(p);
      }
      int validated = 0, nearTruth = 0;
      double bestNear = -1e18, bestAll = -1e18;
      const auto hs = sampler->run(copies_[static_cast<std::size_t>(copy)], active, s, [&](const Eigen::Matrix4d& t) {
        const double sc = quickScore(copy, t, depth, k);
        if (haveTruth) {
          ++validated;
          bestAll = std::max(bestAll, sc);
          const Eigen::Matrix4d m = t * rot;
          if (translationErrorMm(m, truth) < 15 && rotationErrorDeg(m, truth) < 15) {
            ++nearTruth;
            bestNear = std::max(bestNear, sc);
          }
        }
        return sc;
      });
      if (haveTruth)
        std::fprintf(stderr, "  copy %d: %d validated, %d near the truth (best score %.0f vs %.0f)\n", copy, validated, nearTruth, bestNear, bestAll);
      for (const auto& h : hs) {
        Candidate c;
        c.copy = copy;
        c.camFromModel = h.transform * rot;
        out.push_back(c);
      }
      return out;
    }
    // Paper 004 as written: Open3D's RANSAC on whole-model FPFH correspondences.
    std::vector<std::size_t> keep;
    for (std::size_t i = 0; i < active.size(); ++i)
      if (active[i]) keep.push_back(i);
    const PointSet sub = sceneDown.select(keep);
    const auto corres = backend::featureCorrespondences(copies_[static_cast<std::size_t>(copy)], sub, false);
    const auto r = backend::ransacOnCorrespondences(copies_[static_cast<std::size_t>(copy)], sub, corres, 1.5 * params_.voxelMm,
                                                    kPaperEdgeSimilarity, params_.ransacIterations, params_.ransacConfidence);
    if (r.correspondences >= 3) {
      Candidate c;
      c.copy = copy;
      c.camFromModel = r.transform * rot;
      out.push_back(c);
    }
    return out;
  }

  // ICP (coarse, then fine), then the alignment to the depth image's boundaries along the
  // motions ICP leaves weakly determined, and the visibility check.
  void refineCandidate(Candidate& c, const Points& remaining, const cv::Mat& depth, const DepthIntrinsics& k) {
    const double v = params_.voxelMm;
    const double coarse = std::max(2 * v, 0.5 * params_.ransacDistanceMm);
    Eigen::Matrix<double, 6, 6> h;
    const PointSet near = nearPoints(c.camFromModel, remaining, coarse);
    if (near.size() < 30) return;
    for (double d : {coarse, 2 * v, params_.icpDistanceMm})
      if (!icp(c.camFromModel, near, d, params_.icpIterations, c.rmseMm, &h)) return;
    alignToBoundaries(c.camFromModel, h, depth, k);
    c.vis = visibility_.check(c.camFromModel, depth, k, params_.fitnessDistanceMm, params_.visibleMaxAngleDeg, claimed_);
    c.valid = enoughEvidence(c);
  }

  // Cluster search, coarse to fine. Coarse: the ICP stages at the RANSAC / voxel distances on
  // the voxel grid's points (~100-400 near a part instead of ~5000 sensor points), then a
  // gate: false when the visibility check's fitness is below half of f_l or the model lies
  // 10 mm beyond the floor. Fine: the last ICP stage on the sensor's points, the boundary
  // alignment and every check (paper 004 eq. 2 at each stage).
  bool coarseRefine(Candidate& c, const cv::Mat& depth, const DepthIntrinsics& k) {
    const double v = params_.voxelMm;
    const double coarse = std::max(2 * v, 0.5 * params_.ransacDistanceMm);
    const PointSet nearDown = nearDownPoints(c.camFromModel, coarse);
    if (nearDown.size() < kMinIcpPairs) return false;
    for (double d : {coarse, 2 * v})
      if (!icp(c.camFromModel, nearDown, d, params_.icpIterations, c.rmseMm, nullptr, kMinIcpPairs, kCoarseNormalAngleDeg)) return false;
    c.coarseFitness = visibility_.check(c.camFromModel, depth, k, params_.fitnessDistanceMm, params_.visibleMaxAngleDeg, claimed_).fitness;
    if (c.coarseFitness < std::max(params_.retryMinFitness, kCoarseGateShare * params_.fLow)) return false;
    return belowPlane(c.camFromModel) <= params_.maxBelowPlaneMm + kCoarseFloorMarginMm;
  }
  void fineRefine(Candidate& c, const Points& remaining, const cv::Mat& depth, const DepthIntrinsics& k) {
    Eigen::Matrix<double, 6, 6> h;
    const double v = params_.voxelMm;
    const double coarse = std::max(2 * v, 0.5 * params_.ransacDistanceMm);
    const PointSet near = nearPoints(c.camFromModel, remaining, coarse);
    if (near.size() < 30) return;
    for (double d : {coarse, 2 * v, params_.icpDistanceMm})
      if (!icp(c.camFromModel, near, d, params_.icpIterations, c.rmseMm, &h)) return;
    traceErr("fine icp", c.camFromModel);
    alignToBoundaries(c.camFromModel, h, depth, k);
    traceErr("fine boundaries", c.camFromModel);
    c.vis = visibility_.check(c.camFromModel, depth, k, params_.fitnessDistanceMm, params_.visibleMaxAngleDeg, claimed_);
    c.valid = enoughEvidence(c);
  }

  // kMinViewShare: the view must be able to confirm or refute the pose.
  // kMaxContinuation: the part's edge must be an edge in the view.
  // The part lies on or above the removed plane (table, bin floor): a candidate with a model
  // point more than maxBelowPlaneMm beyond it is physically impossible, whatever the view
  // says (the view cannot refute it: the floor hides what is beyond it). Measured on bracket,
  // housing and lever scenes 100-105: every true pose 0.0 mm; the clutter fits the cluster
  // search produced with fitness 0.78-1.00 (a part's side face laid onto a box, the rest of
  // the part "inside" the box and the floor) 41-57 mm; on empty cluttered scenes 16-52 mm.
  bool enoughEvidence(Candidate& c) const {
    c.belowPlaneMm = belowPlane(c.camFromModel);
    return enoughEvidence(c.vis) && c.belowPlaneMm <= params_.maxBelowPlaneMm;
  }
  // The deepest model point beyond the removed plane (mm; 0 when none is, or no plane was removed).
  double belowPlane(const Eigen::Matrix4d& camFromModel) const {
    double below = 0;
    if (!plane_) return below;
    const Eigen::Vector3d n = camFromModel.topLeftCorner<3, 3>().transpose() * plane_->head<3>();  // in the model frame
    const double d = plane_->head<3>().dot(camFromModel.topRightCorner<3, 1>()) + (*plane_)[3];
    for (const auto& p : modelFine_.points()) below = std::max(below, -(n.dot(p) + d));
    return below;
  }
  bool enoughEvidence(const Visibility& v) const {
    const int seen = v.matched + v.occluded + v.contradicted;
    return seen >= minSeen_ && v.continuation <= kMaxContinuation && v.outside <= kMaxOutsideShare * (seen + v.unknown + v.outside) &&
           v.unknown <= kMaxUnknownShare * (seen + v.unknown);
  }

  Candidate refine(Candidate c, const Points& remaining, const cv::Mat& depth, const DepthIntrinsics& k) {
    const PointSet near = nearPoints(c.camFromModel, remaining, params_.icpDistanceMm);
    double rmse = c.rmseMm;
    Eigen::Matrix<double, 6, 6> h;
    if (near.size() < 30 || !icp(c.camFromModel, near, 0.6 * params_.icpDistanceMm, 3 * params_.icpIterations, rmse, &h, 30, kNormalAngleDeg,
                                     kRefineMinEigenShare))
      return c;
    traceErr("refine icp", c.camFromModel);
    alignToBoundaries(c.camFromModel, h, depth, k);
    alignToEdges(c.camFromModel, h, depth, k);
    traceErr("refine boundaries + edges", c.camFromModel);
    c.rmseMm = rmse;
    c.vis = visibility_.check(c.camFromModel, depth, k, params_.fitnessDistanceMm, params_.visibleMaxAngleDeg, claimed_);
    c.valid = enoughEvidence(c);
    return c;
  }

  // The eigen-directions of ICP's J^T J `h` (rotations scaled to mm at the part's radius) and
  // how stiffly ICP's surfaces hold each (eigenvalue / sigma^2, sigma 0.35 mm the sensor
  // noise at the part's distance): the prior of both boundary alignments below.
  void stiffDirections(const Eigen::Matrix<double, 6, 6>& h, std::vector<Eigen::Matrix<double, 6, 1>>& dirs,
                       std::vector<double>& stiff) const {
    Eigen::Matrix<double, 6, 6> s = Eigen::Matrix<double, 6, 6>::Identity();
    s.topLeftCorner<3, 3>() /= radius_;
    const Eigen::SelfAdjointEigenSolver<Eigen::Matrix<double, 6, 6>> eig(s * h * s);
    constexpr double sigma = 0.35;
    for (int i = 0; i < 6; ++i) {
      dirs.push_back(eig.eigenvectors().col(i));
      stiff.push_back(std::max(0.0, eig.eigenvalues()[i]) / (sigma * sigma));
    }
  }

  // The boundary alignment along the eigen-directions of ICP's J^T J (rotations scaled to mm
  // at the part's radius), each held by what ICP's surfaces say against moving along it
  // (eigenvalue / sigma^2, sigma the sensor noise at the part's distance, times the weight):
  // seen from above, the sideways shifts and the turn about the view axis are nearly free
  // and follow the boundaries, the rest stays where ICP put it.
  void alignToBoundaries(Eigen::Matrix4d& camFromModel, const Eigen::Matrix<double, 6, 6>& h, const cv::Mat& depth,
                         const DepthIntrinsics& k) {
    std::vector<Eigen::Matrix<double, 6, 1>> dirs;
    std::vector<double> stiff;
    stiffDirections(h, dirs, stiff);
    camFromModel = visibility_.alignToBoundaries(camFromModel, centroid_, radius_, dirs, stiff, depth, k, params_.fitnessDistanceMm,
                                                 params_.visibleMaxAngleDeg, claimed_);
  }

  // The sub-pixel silhouette alignment (cloud_math.hpp alignToEdges) after alignToBoundaries,
  // with the same eigen-directions and ICP prior; on the accepted candidate only (refine()):
  // on every fine candidate it cost more and was no more accurate (bracket 100-149: rotation
  // error max 0.82 vs 0.56 deg). Measured on scenes 100-149 (docs/3d.md "Orientation"):
  // rotation error max bracket 1.47 -> 0.56 deg, lever 1.31 -> 0.48 deg.
  void alignToEdges(Eigen::Matrix4d& camFromModel, const Eigen::Matrix<double, 6, 6>& h, const cv::Mat& depth, const DepthIntrinsics& k) {
    std::vector<Eigen::Matrix<double, 6, 1>> dirs;
    std::vector<double> stiff;
    stiffDirections(h, dirs, stiff);
    camFromModel = visibility_.alignToEdges(camFromModel, centroid_, radius_, dirs, stiff, depth, k, params_.visibleMaxAngleDeg,
                                            kEdgeSigmaPx, claimed_);
  }

  // The voxel grid's points (sceneDown_, still active) within the model's radius + margin of
  // the candidate's centroid, with their normals.
  PointSet nearDownPoints(const Eigen::Matrix4d& camFromModel, double margin) const {
    const Eigen::Vector3d centre = (camFromModel * centroid_.homogeneous()).head<3>();
    const double r2 = (radius_ + margin) * (radius_ + margin);
    std::vector<std::size_t> idx;
    for (std::size_t i = 0; i < sceneDown_->size(); ++i)
      if ((*activeDown_)[i] && (sceneDown_->points()[i] - centre).squaredNorm() <= r2) idx.push_back(i);
    return sceneDown_->select(idx);
  }

  // The measured points within the model's radius + margin of the candidate's centroid,
  // with normals (towards the camera).
  PointSet nearPoints(const Eigen::Matrix4d& camFromModel, const Points& remaining, double margin) const {
    const Eigen::Vector3d centre = (camFromModel * centroid_.homogeneous()).head<3>();
    const double r2 = (radius_ + margin) * (radius_ + margin);
    Points near;
    for (const auto& p : remaining)
      if ((p - centre).squaredNorm() <= r2) near.push_back(p);
    PointSet out(std::move(near));
    if (out.size() >= 30) out.estimateNormals(kCropNormalRadiusMm, 30, Eigen::Vector3d::Zero());
    return out;
  }

  // Point-to-plane ICP (paper 004 eq. 2) of the measured points near the candidate (source,
  // with normals) onto the model (target, its normals); updates camFromModel. False when
  // fewer than 30 pairs are left.
  // hessian (optional): J^T J in the camera frame (rotation about the part's centroid).
  bool icp(Eigen::Matrix4d& camFromModel, const PointSet& near, double maxDist, int iterations, double& rmse,
           Eigen::Matrix<double, 6, 6>* hessian = nullptr, std::size_t minPairs = 30, double normalAngleDeg = kNormalAngleDeg,
           double minEigenShare = 0) const {
    // Source = measured points, target = model: the model frame's J^T J is turned into the
    // camera frame below.
    const auto res = icpTarget_->align(near, maxDist, normalAngleDeg, camFromModel.inverse(), iterations, centroid_, minEigenShare);
    if (res.correspondences < minPairs) return false;
    camFromModel = res.transform.inverse();
    rmse = res.rmseMm;
    if (hessian) {
      // A small motion (w, t) of the source in the model frame is the inverse motion of the
      // model in the camera frame: rotate both blocks into the camera frame (signs do not
      // change J^T J).
      Eigen::Matrix<double, 6, 6> r = Eigen::Matrix<double, 6, 6>::Zero();
      r.topLeftCorner<3, 3>() = camFromModel.topLeftCorner<3, 3>();
      r.bottomRightCorner<3, 3>() = camFromModel.topLeftCorner<3, 3>();
      *hessian = r * res.hessian * r.transpose();
    }
    return true;
  }

  // Takes a found part's points out of the search: its scene points are no longer sampled,
  // its full-resolution points no longer reach ICP, its pixels no longer count.
  void removeExplained(const Eigen::Matrix4d& camFromModel, const PointSet& sceneDown, std::vector<char>& active, Points& remaining,
                       const cv::Mat& depth, const DepthIntrinsics& k) {
    Points placed;
    placed.reserve(modelFine_.size());
    for (const auto& p : modelFine_.points()) placed.push_back((camFromModel * p.homogeneous()).head<3>());
    const backend::NearestIndex index(placed);
    const double d2 = std::pow(params_.fitnessDistanceMm + params_.voxelMm, 2);
    for (std::size_t i = 0; i < sceneDown.size(); ++i)
      if (active[i] && index.nearest(sceneDown.points()[i]).first <= d2) active[i] = 0;
    std::erase_if(remaining, [&](const Eigen::Vector3d& p) { return index.nearest(p).first <= d2; });
    visibility_.claim(camFromModel, depth, k, params_.fitnessDistanceMm, params_.visibleMaxAngleDeg, claimed_);
  }

  Search3dParams params_;
  Eigen::Matrix4d graspInModel_;
  PointSet modelDown_, modelFine_;
  std::vector<int> poolOwner_;  // model-view feature -> modelDown_ point
  std::unique_ptr<backend::FeatureIndex> featureIndex_;
  std::unique_ptr<backend::IcpTarget> icpTarget_;
  std::unique_ptr<PpfModel> ppf_;  // clusterMm > 0: the hypothesis generator
  std::vector<PointSet> copies_;
  std::vector<Eigen::Matrix4d> copyRotations_;
  Eigen::Vector3d centroid_ = Eigen::Vector3d::Zero();
  double radius_ = 0;
  double diameter_ = 0;  // of modelDown_, mm
  int minSeen_ = 0;  // kMinViewShare x the median visible model points
  VisibilityCheck visibility_;
  cv::Mat claimed_;  // pixels of the parts found in the current call
  std::optional<Eigen::Vector4d> plane_;
  const PointSet* sceneDown_ = nullptr;        // cluster search: the current call's voxel grid, with normals
  const std::vector<char>* activeDown_ = nullptr;  // ... and which of its points no found part explains  // the removed plane (camera on its positive side), if any
};

}  // namespace

std::string_view outcomeName(Outcome3d o) {
  switch (o) {
    case Outcome3d::Found: return "found";
    case Outcome3d::NotFound: return "not_found";
    case Outcome3d::RetryFromNewViewpoint: return "retry_new_viewpoint";
  }
  return "not_found";
}

Result<void> checkSearch3dParams(const Search3dParams& p) {
  for (const auto& key : search3dKeys()) {
    const double v = key.get(p);
    if (!(v >= key.lo && v <= key.hi))
      return fail(Status::BadArgument, fmt::format("search.{}: {} is out of range: expected {}[{}, {}]", key.name, v,
                                                   key.integer ? "an integer in " : "", key.lo, key.hi));
  }
  if (const std::string e = search3dCrossCheck(p); !e.empty()) return fail(Status::BadArgument, "search." + e);
  return {};
}

Result<std::unique_ptr<Locator3d>> makeLocator3d(const PlyCloud& model, const Pose& grasp, const Search3dParams& p) {
  if (auto c = checkSearch3dParams(p); !c) return std::unexpected(c.error());
  if (!model.hasNormals() || model.normals.size() != model.points.size())
    return fail(Status::BadArgument, "the model has no normals (expected x y z nx ny nz per point)");
  if (model.points.size() < 100) return fail(Status::BadArgument, fmt::format("the model has {} points (expected at least 100)", model.points.size()));
  auto loc = std::make_unique<Locator3dImpl>(model, grasp, p);
  return std::unique_ptr<Locator3d>(std::move(loc));
}

}  // namespace vgr::vision::cloud
