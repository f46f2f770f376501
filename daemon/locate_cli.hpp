// `vgr` subcommands for localization (papers 000-002; docs/localization.md, docs/datasets.md):
//   vgr sim render   datasets with ground truth from the part renderer
//   vgr teach        a job folder from a template image and its grasp point
//   vgr locate       run a job's method on one image, JSON out
//   vgr eval         run a job's method over a dataset, accuracy and time, JSON out
// Usage in main: LocateCommands cmds(app); CLI11_PARSE(...); if (int rc = cmds.run(); rc >= 0) return rc;
#pragma once

#include <memory>

namespace CLI {
class App;
}

namespace vgr::daemon {

class LocateCommands {
 public:
  explicit LocateCommands(CLI::App& app);
  ~LocateCommands();
  // The exit code of the subcommand that ran, or -1 when none of these ran.
  int run();

 private:
  struct State;
  std::unique_ptr<State> state_;
};

}  // namespace vgr::daemon
