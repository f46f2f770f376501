// vgr: the offline tool. Subcommands, one file each in tools/vgr/:
//   vgr demo [--cycles N]     run the simulated cell end to end (docs/demo.md)
//   vgr check --config FILE   validate a cell config
//   vgr cameras [--json]      list the GigE Vision cameras on the network (docs/cameras.md)
//   vgr grab --camera ID ...  trigger N frames, report errors and latency (docs/cameras.md)
//   vgr calibrate intrinsics|handeye|plane|synth|verify ...   calibration (docs/calibration.md)
//   vgr repeatability --config CELL --shots N   spread of a still part (docs/commissioning.md)
//   vgr sim render | teach | locate | eval   localization datasets, jobs, runs (docs/localization.md)
//   vgr classify train | eval   paper 002's part classifier (docs/classification.md)
//   vgr soak [--triggers N]   fault-injection run of the simulated cell (docs/robustness.md)
//   vgr journal-bench         the journal's write and fdatasync cost per record (docs/journal.md)
//   vgr replay --journal J --archive A --job DIR   a changed job on archived frames (docs/commissioning.md)
//   vgr grasp detect | tensors  grasp detection in depth images (docs/grasp.md; scored by vgr eval --grasp)
#include <map>
#include <memory>
#include <string>
#include <utility>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"

#include "core/version.hpp"

#include "tools/vgr/calibrate_handeye.hpp"
#include "tools/vgr/calibrate_intrinsics.hpp"
#include "tools/vgr/calibrate_plane.hpp"
#include "tools/vgr/calibrate_synth.hpp"
#include "tools/vgr/calibrate_verify.hpp"
#include "tools/vgr/classify.hpp"
#include "tools/vgr/cameras.hpp"
#include "tools/vgr/check.hpp"
#include "tools/vgr/demo.hpp"
#include "tools/vgr/eval.hpp"
#include "tools/vgr/grab.hpp"
#include "tools/vgr/grasp.hpp"
#include "tools/vgr/locate.hpp"
#include "tools/vgr/journal_bench.hpp"
#include "tools/vgr/repeatability.hpp"
#include "tools/vgr/replay.hpp"
#include "tools/vgr/model.hpp"
#include "tools/vgr/sim_render.hpp"
#include "tools/vgr/soak.hpp"
#include "tools/vgr/subcommand.hpp"
#include "tools/vgr/teach.hpp"

namespace {

using vgr::tools::Subcommand;

// Subcommands that only group others (`vgr calibrate intrinsics`, `vgr sim render`).
struct Group {
  const char* name;
  const char* description;
};
constexpr Group kGroups[] = {
    {"calibrate", "camera intrinsics, hand-eye, work plane, synthetic calibration data, verify"},
    {"sim", "simulation tools"},
    {"classify", "part classifier of paper 002: train, eval (docs/classification.md)"},
    {"grasp", "grasp detection in depth images (paper 003): detect, tensors (docs/grasp.md)"},
    {"model", "3D part models from depth views: build, eval (docs/3d.md)"},
};

struct Entry {
  const char* group;  // nullptr: a top-level subcommand; else one of kGroups
  std::unique_ptr<Subcommand> command;
};

}  // namespace

int main(int argc, char** argv) {
  namespace tools = vgr::tools;
  CLI::App app{"vgr: vision-guided robotics tool"};
  vgr::cli::showDefaults(app);
  app.set_version_flag("--version", std::string("vgr ") + vgr::buildVersion());
  app.require_subcommand(1);

  // Every subcommand, in the order `vgr --help` lists them.
  Entry table[] = {
      {nullptr, std::make_unique<tools::DemoCommand>()},
      {nullptr, std::make_unique<tools::SoakCommand>()},
      {nullptr, std::make_unique<tools::CheckCommand>()},
      {nullptr, std::make_unique<tools::CamerasCommand>()},
      {nullptr, std::make_unique<tools::GrabCommand>()},
      {"calibrate", std::make_unique<tools::CalibrateIntrinsicsCommand>()},
      {"calibrate", std::make_unique<tools::CalibrateHandEyeCommand>()},
      {"calibrate", std::make_unique<tools::CalibratePlaneCommand>()},
      {"calibrate", std::make_unique<tools::CalibrateSynthCommand>()},
      {"calibrate", std::make_unique<tools::CalibrateVerifyCommand>()},
      {"sim", std::make_unique<tools::SimRenderCommand>()},
      {nullptr, std::make_unique<tools::TeachCommand>()},
      {nullptr, std::make_unique<tools::LocateCommand>()},
      {nullptr, std::make_unique<tools::EvalCommand>()},
      {nullptr, std::make_unique<tools::RepeatabilityCommand>()},
      {nullptr, std::make_unique<tools::ReplayCommand>()},
      {"classify", std::make_unique<tools::ClassifyTrainCommand>()},
      {"classify", std::make_unique<tools::ClassifyEvalCommand>()},
      {"model", std::make_unique<tools::ModelBuildCommand>()},
      {"model", std::make_unique<tools::ModelEvalCommand>()},
      {nullptr, std::make_unique<tools::JournalBenchCommand>()},
      {"grasp", std::make_unique<tools::GraspDetectCommand>()},
      {"grasp", std::make_unique<tools::GraspTensorsCommand>()},
  };

  std::map<std::string, CLI::App*> groups;  // added when their first member is
  auto groupApp = [&](const std::string& name) {
    CLI::App*& g = groups[name];
    if (!g)
      for (const auto& k : kGroups)
        if (name == k.name) {
          g = app.add_subcommand(k.name, k.description);
          g->require_subcommand(1);
        }
    return g;
  };
  std::vector<std::pair<CLI::App*, Subcommand*>> added;
  for (auto& e : table) added.emplace_back(e.command->add(e.group ? *groupApp(e.group) : app), e.command.get());

  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  for (const auto& [cli, command] : added)
    if (*cli) return command->run();
  return 0;
}
