// `vgr demo`: the whole simulated cell as separate processes on loopback — camera emulator,
// vgrd, PLC simulator, one UR-dialect and one ABB-dialect robot simulator — for N cycles,
// each checked against the renderer's ground truth. See docs/demo.md.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "tools/vgr/subcommand.hpp"

namespace vgr::tools {

struct DemoOptions {
  int cycles = 50;
  std::string configPath;      // empty: the embedded config/examples/sim-cell.yaml
  std::string binDir;          // where vgrd and the simulators are; empty: next to this executable
  std::string workDir;         // empty: a fresh folder under /tmp
  int intervalMs = 0;          // PLC pause between cycles
  std::int64_t seed = -1;      // scene seed; -1: the config's sim.seed
  bool quiet = false;          // no per-cycle lines
  // Non-empty: run a job of this localization method instead of the example's `moments`
  // job, taught with `vgr teach` on the textured part (sim.scene `part` unless the config
  // says `multi`), the way an integrator teaches a reference part. Embedded config only.
  std::string method;
  std::string scene;           // with `method`: part (default) or multi (sim.scene, docs/ground-truth.md)
  // Non-empty: paper 002's sorting cell (docs/demo.md "Sorting"): these part classes mixed
  // in every frame (sim.classes), a job of `method` (moments: every blob a part) with a
  // classifier `vgr classify train` makes from a rendered training set, and four robots each
  // served by its own part order (best_score, by_label, label_only, random) with reply_label
  // on; each robot simulator checks that it got exactly the parts its order says.
  std::vector<std::string> classes;
  int parts = 4;               // with `classes`: parts per frame, [1, 16]
  // The simulated 3D cell (docs/demo.md "3D"): the embedded config/examples/sim-cell-3d.yaml,
  // the depth camera emulator serving `cycles` rendered scenes (demo3d.hpp) with their truth,
  // each pose compared in six DoF with the truth in the robot base frame (<= 1 mm, <= 1 deg).
  bool threeD = false;
};

// Returns the process exit code: 0 when every cycle delivered a pose and every robot reply
// was well-formed, 1 otherwise, 2 when the cell could not be started.
int runDemo(const DemoOptions& options);

class DemoCommand final : public OptionsSubcommand<DemoOptions, runDemo> {
 public:
  CLI::App* add(CLI::App& parent) override;
};

}  // namespace vgr::tools
