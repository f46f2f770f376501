// `vgr teach`: a job folder (job.yaml + template.png) from a template image and its grasp
// point(s) (docs/localization.md). The method must accept the template before anything is
// written; the job is read back after writing. Exit code 0, or 2 with the message on stderr.
#pragma once

#include <string>
#include <vector>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct TeachOptions {
  std::string image, out, method = "moments", roi, regionsFile, name;
  std::vector<std::string> grasps, params;
  double minScore = 0.5, angleMin = -180, angleMax = 180, partHeightMm = 0;
  int maxParts = 1;
  bool autoRegions = true;
  // --polarity: params.polarity of moments, hu and shape (use | ignore_global | ignore_local);
  // empty = the method's default (use). A --param polarity=... says the same; both: an error.
  std::string polarity;
};

int runTeach(const TeachOptions& o);

class TeachCommand final : public OptionsSubcommand<TeachOptions, runTeach> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
