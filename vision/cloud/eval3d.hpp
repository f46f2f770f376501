// Scoring 3D localization against ground truth (docs/3d.md "Evaluation"), shared by
// `vgr eval` on 3D data sets and vgr-bench-cloud. Pure code, no Open3D; one thread.
//
// Per image, found parts and true parts are paired greedily by the distance of their model
// origins (closest first, at most pairTolMm apart). A pair is a success when the translation
// error is <= transTolMm and the rotation error (angle of R_true^T R_found) <= rotTolDeg
// (defaults 2 mm / 2 deg: paper 003's grasp accuracy). A found part that is not a success is
// a false pose (a wrong answer); a true part without a success is missed. An image without a
// part is a success when nothing is found. ADD: mean distance of the model's points under
// the found and the true pose (Hinterstoisser et al. 2012), over paired parts. Errors (mean,
// max) are over paired parts.
#pragma once

#include <array>
#include <vector>

#include "core/pose.hpp"
#include "vision/cloud/locator3d.hpp"

namespace vgr::vision::cloud {

struct Eval3dOptions {
  double transTolMm = 2, rotTolDeg = 2;
  double pairTolMm = 20;  // farther apart: not the same part
};

struct Eval3dSummary {
  int images = 0, emptyImages = 0, parts = 0;
  int successes = 0;       // true parts found within tolerance
  int emptySuccesses = 0;  // empty images with nothing found
  int missed = 0, falsePositives = 0, retries = 0, notFound = 0;
  int paired = 0;
  double transErrMean = 0, transErrMax = 0, rotErrMean = 0, rotErrMax = 0, addMean = 0;  // mm, deg, mm
  double timeMsMedian = 0, cpuMsMedian = 0, timeMsMax = 0;
  // (successes + emptySuccesses) / (parts + emptyImages)
  double successRate() const;
};

class Eval3dAccumulator {
 public:
  // modelPoints: the model (model frame, mm) for ADD; a few thousand points are plenty.
  Eval3dAccumulator(std::vector<std::array<double, 3>> modelPoints, Eval3dOptions options);
  // One image: its true parts (empty = an image without a part), what the locator said, and
  // how long it took (wall and CPU ms).
  void add(const std::vector<Pose>& truth, const Locate3dResult& result, double wallMs, double cpuMs);
  Eval3dSummary summary() const;

  // The last image's pairing, for per-image reports.
  struct Pair {
    int found = -1, truth = -1;  // indices; -1 = none
    double transErrMm = 0, rotErrDeg = 0, addMm = 0;
    bool success = false;
  };
  const std::vector<Pair>& lastPairs() const { return last_; }

 private:
  std::vector<std::array<double, 3>> model_;
  Eval3dOptions o_;
  Eval3dSummary s_;
  std::vector<double> trans_, rot_, add_, wall_, cpu_;
  std::vector<Pair> last_;
};

}  // namespace vgr::vision::cloud
