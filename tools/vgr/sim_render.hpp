// `vgr sim render`: a data set with ground truth. 2D (default): the part renderer's gray
// images (docs/datasets.md); prints {"out","images","empty_images","parts"}. With --3d: the
// depth renderer's data set in the fixed 3D format (docs/3d.md); prints {"out","images",
// "empty_images","parts","views"}. Exit code 0, or 2 with the message on stderr (an option
// of the other mode, a value out of range, an output folder that is not empty).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "sim/dataset.hpp"
#include "sim/depth_dataset.hpp"
#include "tools/vgr/subcommand.hpp"

namespace CLI {
class Option;
}

namespace vgr::tools {

struct SimRenderOptions {
  bool threeD = false;
  sim::DatasetOptions flat;        // 2D
  sim::DepthDatasetOptions depth;  // --3d
  // Options both modes have, with a different default (or meaning) in each: applied by run.
  std::string out, part;
  std::optional<int> count, clutter, parts, width, height;
  std::optional<std::uint64_t> seed;
  std::optional<double> noise, emptyRatio, focal;
  // Options given on the command line that belong to the other mode (set by the command).
  std::vector<std::string> wrongMode;
};

int runSimRender(const SimRenderOptions& o);

class SimRenderCommand final : public OptionsSubcommand<SimRenderOptions, runSimRender> {
 public:
  CLI::App* add(CLI::App& parent) override;
  int run() override;

 private:
  std::vector<CLI::Option*> only2d_, only3d_;
};

}  // namespace vgr::tools
