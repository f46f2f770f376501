// `vgr sim render`: a localization dataset with ground truth from the part renderer
// (docs/datasets.md). Prints one JSON line {"out","images","empty_images","parts"};
// exit code 0, or 2 with the message on stderr.
#pragma once

#include "sim/dataset.hpp"
#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

int runSimRender(const sim::DatasetOptions& o);

class SimRenderCommand final : public OptionsSubcommand<sim::DatasetOptions, runSimRender> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
