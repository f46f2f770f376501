// The scoring behind `vgr eval`: a job's method run over a dataset (docs/datasets.md) and
// scored against the truth (docs/localization.md "Evaluation"). Offline tool code, one thread.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "core/result.hpp"

namespace vgr::tools {

struct EvalOptions {
  std::string jobFolder;
  std::string datasetFolder;
  std::string method;         // empty = the job's
  double posTolPx = 4;        // paper 000: success at <= 4 px ...
  double angTolDeg = 0.5;     // ... and <= 0.5 deg
  // A detection is paired with a truth part only within this distance of its grasp point
  // (px); farther, it is a false positive and the part is missed. 0 = posTolPx. A larger
  // value keeps near misses in the error curves (paired, counted as failures).
  double pairTolPx = 0;
  double matchTolPx = 5;      // paper 001's 5 px boundary: a feature match within this of its true place is correct
  double graspTpMm = 3, graspTpDeg = 2;  // paper 001's true positive: < 3 mm and < 2 deg
  int limit = 0;              // evaluate the first N images only; 0 = all
  std::string plotPath;       // sorted error curves (paper 000, Fig. 7); empty = none
  std::string overlaysDir;    // one overlay picture per image (vision/overlay.hpp, as `vgr locate --overlay`); empty = none
};

struct EvalReport {
  std::string method;
  int n = 0;                  // samples: truth parts + images without a part
  int images = 0, emptyImages = 0, parts = 0;
  int successes = 0;
  int missed = 0;             // truth parts with no detection within the pairing tolerance
  int falsePositives = 0;     // detections not paired with a truth part (incl. on empty images)
  int countCorrectImages = 0; // images where every truth part was paired and no detection was left over
  std::vector<double> posErrPx, angErrDeg, timeMs;  // per matched part / per image
  long matchesTotal = 0, matchesTrue = 0;           // feature methods
  std::optional<double> graspTpRate;                // when the dataset gives the scale (dataset.yaml)
  std::vector<std::string> unreadable;              // "PATH: why" per image left out (not counted in n)

  double successRate() const { return n ? double(successes) / n : 0; }
};

// Errors: the job or the truth cannot be read, truth.csv lists no image, no image can be
// read. An image that cannot be read is listed in EvalReport::unreadable and left out.
Result<EvalReport> evaluate(const EvalOptions& options);

// truth.csv of a dataset (docs/datasets.md), grouped by image in file order.
struct TruthPart {
  double u = 0, v = 0, angleDeg = 0;
  bool hasPose = false;  // x_mm, y_mm, rz_deg columns present (vgr sim render datasets)
  double xMm = 0, yMm = 0, rzDeg = 0;
  std::string label;     // the `label` column (a class name), empty when absent
};
struct TruthImage {
  std::string image;
  std::vector<TruthPart> parts;  // empty = no part in the image
};
// Errors name the file and line.
Result<std::vector<TruthImage>> readTruth(const std::string& folder);

// One JSON object (no newline) with the keys of docs/localization.md: n, success_rate, pos_err_px_mean,
// pos_err_px_max, ang_err_deg_mean, ang_err_deg_max, time_ms_median, and the rest.
std::string evalJson(const EvalReport& report, const EvalOptions& options);

// Draws the sorted position and angle error curves (paper 000, Fig. 7) into a PNG.
Result<void> plotErrors(const EvalReport& report, const EvalOptions& options, const std::string& path);

}  // namespace vgr::tools
