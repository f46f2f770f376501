// `vgr eval` on a 3D data set (docs/3d.md "Evaluation"): a job of kind 3d (config/job3d.hpp)
// run over DIR's depth images (the fixed 3D data-set format: camera.yaml, images/*.png,
// truth.csv) and scored against the truth by vision/cloud/eval3d.hpp: success at
// --trans-tol mm and --rot-tol deg (default 2 / 2), errors, ADD, misses, false poses,
// retries, time. Everything is read and checked before the first image is located; one
// bad file -> exit 2 with one line naming it. Prints a summary line (unless --json) and one
// JSON line holding success_rate, trans_err_mm_mean, trans_err_mm_max, rot_err_deg_mean,
// rot_err_deg_max, add_mm_mean, missed, false_positives, retries, time_ms_median (the keys
// issue 13 fixes) and more.
#pragma once

#include <string>

namespace vgr::tools {

struct Eval3dCliOptions {
  std::string jobFolder, datasetFolder;
  double transTolMm = 2, rotTolDeg = 2;
  int limit = 0;  // first N images only; 0 = all
  bool json = false;
};

int runEval3d(const Eval3dCliOptions& o);

}  // namespace vgr::tools
