#include "tools/vgr/eval.hpp"

#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job3d.hpp"
#include "tools/vgr/calibrate_common.hpp"
#include "tools/vgr/eval3d.hpp"

namespace vgr::tools {

int runEval(const EvalCliOptions& options) {
  const EvalOptions& o = options.scoring;
  // A 3D job (kind: 3d) runs on a 3D data set (docs/3d.md); 2D jobs as before.
  if (auto kind = config::jobKind(o.jobFolder); kind && *kind == "3d") {
    if (!o.method.empty() || !o.plotPath.empty() || !o.overlaysDir.empty())
      return badInput("vgr eval: --method, --plot and --overlays are for 2D jobs; " + o.jobFolder + " is a 3D job");
    return runEval3d({o.jobFolder, o.datasetFolder, options.transTolMm, options.rotTolDeg, o.limit, options.json});
  } else if (!kind && std::filesystem::exists(std::filesystem::path(o.jobFolder) / "job.yaml")) {
    return badInput(kind.error().message);
  }
  // The plot's path before the run, not after it (a long evaluation lost at its end).
  if (!o.plotPath.empty()) {
    if (auto w = checkOutputPath(o.plotPath, "--plot"); !w) return badInput(w.error().message);
    if (!cv::haveImageWriter(o.plotPath)) return badInput(o.plotPath + ": --plot needs a .png (or another image) file name");
  }
  auto rep = evaluate(o);
  if (!rep) return badInput(rep.error().message);
  for (const auto& u : rep->unreadable) std::fprintf(stderr, "vgr eval: left out: %s\n", u.c_str());
  if (!o.plotPath.empty())
    if (auto p = plotErrors(*rep, o, o.plotPath); !p) return badInput(p.error().message);
  if (!options.json) {
    std::printf("%s on %s: %d samples (%d parts, %d empty images), success %.1f %% at <= %.2f px / <= %.2f deg\n",
                rep->method.c_str(), o.datasetFolder.c_str(), rep->n, rep->parts, rep->emptyImages, 100 * rep->successRate(),
                o.posTolPx, o.angTolDeg);
  }
  std::printf("%s\n", evalJson(*rep, o).c_str());
  return 0;
}

CLI::App* EvalCommand::add(CLI::App& parent) {
  auto& e = options_.scoring;
  auto* evalCmd = parent.add_subcommand("eval", "run a job's method over a dataset and score it (docs/localization.md)");
  evalCmd->add_option("--job", e.jobFolder, "job folder")->required();
  evalCmd->add_option("--dataset", e.datasetFolder, "dataset folder (truth.csv; a 3D job: a 3D data set, docs/3d.md)")->required();
  evalCmd->add_option("--method", e.method, "override the job's method");
  evalCmd->add_option("--pos-tol", e.posTolPx, "success: position error <= PX")->check(CLI::Range(0.0, 1e6));
  evalCmd->add_option("--pair-tol", e.pairTolPx,
                      "a detection farther than PX from every truth part is a false positive and the part missed "
                      "(default: --pos-tol)")
      ->check(CLI::Range(0.0, 1e6));
  evalCmd->add_option("--ang-tol", e.angTolDeg, "success: angle error <= DEG")->check(CLI::Range(0.0, 180.0));
  evalCmd->add_option("--match-tol", e.matchTolPx, "a feature match is correct within PX of its true place")->check(CLI::Range(0.0, 1e6));
  evalCmd->add_option("--limit", e.limit, "first N images only")->check(CLI::Range(0, 100000000));
  evalCmd->add_option("--plot", e.plotPath, "PNG of the sorted error curves (paper 000, Fig. 7)");
  evalCmd->add_option("--overlays", e.overlaysDir, "write one overlay picture per image into DIR (as vgr locate --overlay)");
  evalCmd->add_option("--trans-tol", options_.transTolMm, "3D job: success at translation error <= MM")->check(CLI::Range(0.0, 1e6));
  evalCmd->add_option("--rot-tol", options_.rotTolDeg, "3D job: success at rotation error <= DEG")->check(CLI::Range(0.0, 180.0));
  evalCmd->add_flag("--json", options_.json, "only the final JSON line");
  return evalCmd;
}

}  // namespace vgr::tools
