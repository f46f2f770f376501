// Point-pair-feature voting (Drost et al. 2010, "Model globally, match locally"), the
// hypothesis generator of the 3D locator's cluster search (docs/3d.md "Hypotheses"). It
// replaces paper 004 Sec. 3.2 step 2 (RANSAC on FPFH correspondences) where that step fails:
// on our parts' partial views (boxes and cylinders seen from one side, ~100-400 points at a
// 3 mm voxel) FPFH nearest neighbours were almost never right, and RANSAC produced no
// hypothesis within 15 mm / 15 deg of the truth on the misses (docs/3d.md "Measured").
// A pair of oriented points (p1, n1), (p2, n2) has the rotation- and translation-invariant
// feature F = (|d|, angle(n1, d), angle(n2, d), angle(n1, n2)), d = p2 - p1. Every model
// pair is stored under its quantised F; every scene pair looks its F up and each model pair
// found votes for (model reference point, rotation alpha about the reference normal): the
// peak is a full 6-DOF pose from one scene reference point.
//
// Why our own and not OpenCV contrib's ppf_match_3d::PPF3DDetector: we vote per cluster
// with the clusters' camera-facing normals and hand every reference point's peak to the
// locator's own ranking (visibility, ICP); the detector matches a whole scene and returns
// its own clustered poses only. ~150 lines, no dependency.
//
// Units mm, radians inside; normals: model outward, scene towards the camera (both then
// point out of the part's surface). Immutable after construction; match() is const and
// thread-compatible (scratch is local).
#pragma once

#include <cstdint>
#include <vector>

#include <Eigen/Core>

namespace vgr::vision::cloud {

class PpfModel {
 public:
  // points / normals (unit, outward) of the model, model frame; distStepMm and angleStepDeg
  // quantise F; alphaBins the rotation about the reference normal. Pairs farther apart than
  // the model's diameter cannot occur; pairs whose normals differ by more than
  // maxNormalAngleDeg cannot both face one camera and are not stored. A key shared by more
  // than maxBucketShare x (model points) pairs is dropped (coplanar pairs of big faces).
  PpfModel(std::vector<Eigen::Vector3d> points, std::vector<Eigen::Vector3d> normals, double distStepMm, double angleStepDeg,
           int alphaBins, double maxNormalAngleDeg, double maxBucketShare = 1e9);

  struct Vote {
    Eigen::Matrix4d sceneFromModel = Eigen::Matrix4d::Identity();
    int votes = 0;
  };
  // Scene points / normals (one cluster, camera frame): every refStep-th point is a
  // reference paired with all others; each reference's peak is returned (votes > 0).
  std::vector<Vote> match(const std::vector<Eigen::Vector3d>& points, const std::vector<Eigen::Vector3d>& normals, int refStep) const;

  std::size_t pairs() const { return votes_.size(); }
  std::size_t size() const { return points_.size(); }

 private:
  struct Entry {
    std::uint32_t key;
    std::uint32_t point;  // model reference point
    float alpha;          // rotation of the pair about the reference normal into the x-y half-plane
  };
  // What the voting loop reads of an entry: its first accumulator cell (point x alphaBins)
  // and its alpha; the entries of one key are votes_[first_[i], first_[i + 1]) for keys_[i].
  struct Slot {
    std::uint32_t cell;
    float alpha;
  };
  bool key(const Eigen::Vector3d& p1, const Eigen::Vector3d& n1, const Eigen::Vector3d& p2, const Eigen::Vector3d& n2,
           std::uint32_t& out) const;

  std::vector<Eigen::Vector3d> points_, normals_;
  std::vector<Eigen::Matrix4d> frames_;  // per model point: T_g (point to origin, normal to +x)
  std::vector<std::uint32_t> keys_;      // the stored keys, ascending, each once
  std::vector<std::uint32_t> first_;     // keys_.size() + 1 offsets into votes_
  std::vector<Slot> votes_;              // the entries, sorted by key
  double distStep_, angleStep_, maxDist_, cosMaxNormal_;
  int alphaBins_;
  std::size_t maxBucket_;
};

}  // namespace vgr::vision::cloud
