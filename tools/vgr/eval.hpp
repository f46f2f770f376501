// `vgr eval`: runs a job's method over a dataset and scores it against the truth
// (docs/localization.md "Evaluation"; the scoring is tools/vgr/eval_report.hpp). Prints a
// summary line (unless --json) and one JSON line; exit code 0, or 2 with the message on stderr.
#pragma once

#include "tools/vgr/eval_report.hpp"
#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct EvalCliOptions {
  EvalOptions scoring;
  bool json = false;  // only the final JSON line
  // A job of kind 3d (tools/vgr/eval3d.hpp): success at <= these.
  double transTolMm = 2, rotTolDeg = 2;
};

int runEval(const EvalCliOptions& options);

class EvalCommand final : public OptionsSubcommand<EvalCliOptions, runEval> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
