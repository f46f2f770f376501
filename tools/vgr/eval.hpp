// `vgr eval`: runs a job's method over a dataset and scores it against the truth
// (docs/localization.md "Evaluation"; the scoring is tools/vgr/eval_report.hpp). Prints a
// summary line (unless --json) and one JSON line; exit code 0, or 2 with the message on stderr.
// With --grasp (no job): the grasp detectors on a grasp data set (tools/vgr/grasp_eval.hpp,
// docs/grasp.md "Evaluation").
#pragma once

#include <string>

#include "tools/vgr/eval_report.hpp"
#include "tools/vgr/grasp_eval.hpp"
#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct EvalCliOptions {
  EvalOptions scoring;
  bool json = false;  // only the final JSON line
  // A job of kind 3d (tools/vgr/eval3d.hpp): success at <= these.
  double transTolMm = 2, rotTolDeg = 2;
  bool grasp = false;            // --grasp: grasp detectors instead of a job
  GraspEvalOptions grasps;       // --grasp's options (the data set is scoring.datasetFolder)
  std::string graspDetectors = "ggcnn,analytic";
};

int runEval(const EvalCliOptions& options);

class EvalCommand final : public OptionsSubcommand<EvalCliOptions, runEval> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
