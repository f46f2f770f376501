// `vgr eval --grasp`: the grasp detectors on a grasp data set (docs/grasp.md "Evaluation").
// Each detector's best grasp per image is scored against the image's true rectangles
// (vision/grasp/grasp_metrics.hpp): the rectangle metric (IoU >= 0.25 and angle within
// 30 deg) and paper 003's 2 mm position bound. All detectors run on the same images.
// Offline tool code, one thread.
#pragma once

#include <string>
#include <vector>

#include "core/result.hpp"
#include "vision/grasp/grasp_detector.hpp"
#include "vision/grasp/grasp_metrics.hpp"

namespace vgr::tools {

struct GraspEvalOptions {
  std::string datasetFolder;
  std::vector<std::string> detectors{"ggcnn", "analytic"};
  vision::grasp::GraspDetectorOptions detector;  // detector name is set per run
  vision::grasp::RectMetric metric;
  double posTolMm = 2;   // paper 003: within 2 mm
  int limit = 0;         // first N images; 0 = all
};

struct GraspDetectorReport {
  std::string detector;
  int graspable = 0;        // images with at least one true rectangle
  int found = 0;            // of those, images where the detector gave a grasp
  int rectSuccesses = 0;    // ... whose best grasp matches by the rectangle metric
  int posSuccesses = 0;     // ... and lies within posTolMm of a true centre
  int falsePositives = 0;   // grasps on images with nothing graspable
  std::vector<double> posErrMm, angErrDeg, timeMs;  // per matched grasp / per image
  double rectSuccessRate() const { return graspable ? double(rectSuccesses) / graspable : 0; }
  double posSuccessRate() const { return graspable ? double(posSuccesses) / graspable : 0; }
};

struct GraspEvalReport {
  std::string dataset;
  int images = 0, graspable = 0;
  std::vector<GraspDetectorReport> detectors;
};

// Errors: the data set or a detector cannot be loaded, a depth image is unreadable or of
// the wrong size (the message names the file).
Result<GraspEvalReport> evaluateGrasps(const GraspEvalOptions& options);

// One JSON object (no newline): dataset, images, graspable, and per detector (keyed by
// name) rect_success_rate, pos_success_rate, found, false_positives, pos_err_mm_mean,
// pos_err_mm_median, pos_err_mm_max, ang_err_deg_mean, time_ms_median, with the metric used.
std::string graspEvalJson(const GraspEvalReport& report, const GraspEvalOptions& options);

}  // namespace vgr::tools
