#include "tools/vgr/eval.hpp"

#include <cstdio>
#include <filesystem>
#include <vector>

#include <CLI/CLI.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job3d.hpp"
#include "tools/vgr/calibrate_common.hpp"
#include "tools/vgr/eval3d.hpp"

namespace vgr::tools {

namespace {

int runGraspEval(const EvalCliOptions& options) {
  GraspEvalOptions g = options.grasps;
  g.datasetFolder = options.scoring.datasetFolder;
  g.limit = options.scoring.limit;
  g.detectors.clear();
  std::string rest = options.graspDetectors + ",";
  for (std::size_t at; (at = rest.find(',')) != std::string::npos; rest.erase(0, at + 1))
    if (at > 0) g.detectors.push_back(rest.substr(0, at));
  auto rep = evaluateGrasps(g);
  if (!rep) return badInput(rep.error().message);
  if (!options.json)
    for (const auto& d : rep->detectors)
      std::printf("%s on %s: %d images (%d graspable): rectangle metric %.1f %%, within %.1f mm %.1f %%, found %d, false positives %d\n",
                  d.detector.c_str(), g.datasetFolder.c_str(), rep->images, rep->graspable, 100 * d.rectSuccessRate(), g.posTolMm,
                  100 * d.posSuccessRate(), d.found, d.falsePositives);
  std::printf("%s\n", graspEvalJson(*rep, g).c_str());
  return 0;
}

}  // namespace

int runEval(const EvalCliOptions& options) {
  if (options.grasp) {
    if (!options.scoring.jobFolder.empty()) return badInput("vgr eval: --grasp evaluates grasp detectors, not a job: leave out --job");
    return runGraspEval(options);
  }
  if (options.scoring.jobFolder.empty()) return badInput("vgr eval: --job is required (or --grasp for the grasp detectors)");
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
  std::vector<CLI::Option*> jobOnly;  // not for --grasp
  jobOnly.push_back(evalCmd->add_option("--job", e.jobFolder, "job folder (required unless --grasp)"));
  evalCmd->add_option("--dataset", e.datasetFolder, "dataset folder (truth.csv; a 3D job: a 3D data set, docs/3d.md; --grasp: a depth data set with grasps.csv)")->required();
  jobOnly.push_back(evalCmd->add_option("--method", e.method, "override the job's method"));
  jobOnly.push_back(evalCmd->add_option("--pos-tol", e.posTolPx, "success: position error <= PX")->check(CLI::Range(0.0, 1e6)));
  jobOnly.push_back(evalCmd->add_option("--pair-tol", e.pairTolPx,
                      "a detection farther than PX from every truth part is a false positive and the part missed "
                      "(default: --pos-tol)")
      ->check(CLI::Range(0.0, 1e6)));
  jobOnly.push_back(evalCmd->add_option("--ang-tol", e.angTolDeg, "success: angle error <= DEG")->check(CLI::Range(0.0, 180.0)));
  jobOnly.push_back(evalCmd->add_option("--match-tol", e.matchTolPx, "a feature match is correct within PX of its true place")->check(CLI::Range(0.0, 1e6)));
  evalCmd->add_option("--limit", e.limit, "first N images only")->check(CLI::Range(0, 100000000));
  jobOnly.push_back(evalCmd->add_option("--plot", e.plotPath, "PNG of the sorted error curves (paper 000, Fig. 7)"));
  jobOnly.push_back(evalCmd->add_option("--overlays", e.overlaysDir, "write one overlay picture per image into DIR (as vgr locate --overlay)"));
  jobOnly.push_back(evalCmd->add_option("--trans-tol", options_.transTolMm, "3D job: success at translation error <= MM")->check(CLI::Range(0.0, 1e6)));
  jobOnly.push_back(evalCmd->add_option("--rot-tol", options_.rotTolDeg, "3D job: success at rotation error <= DEG")->check(CLI::Range(0.0, 180.0)));
  evalCmd->add_flag("--json", options_.json, "only the final JSON line");
  auto& g = options_.grasps;
  // Grasp detectors on a grasp data set (docs/grasp.md "Evaluation"). Their options need
  // --grasp: given to a job's evaluation they would be ignored, so CLI11 refuses them (exit 2).
  auto* graspFlag = evalCmd->add_flag("--grasp", options_.grasp, "grasp detectors on a data set made with vgr sim render --3d --grasps (docs/grasp.md)");
  evalCmd->add_option("--detectors", options_.graspDetectors, "--grasp: comma-separated detectors (default ggcnn,analytic)")->needs(graspFlag);
  evalCmd->add_option("--model", g.detector.modelPath, "--grasp: the grasp network, an ONNX file (models/grasp/ggcnn.onnx)")->needs(graspFlag);
  evalCmd->add_option("--min-quality", g.detector.minQuality, "--grasp: ggcnn peaks below Q are not grasps (default 0.2)")
      ->check(CLI::Range(0.0, 1.0))
      ->needs(graspFlag);
  evalCmd->add_option("--min-iou", g.metric.minIou, "--grasp: rectangle metric IoU (default 0.25)")->check(CLI::Range(0.0, 1.0))->needs(graspFlag);
  evalCmd->add_option("--max-angle", g.metric.maxAngleDeg, "--grasp: rectangle metric angle, DEG (default 30)")
      ->check(CLI::Range(0.0, 90.0))
      ->needs(graspFlag);
  evalCmd->add_option("--grasp-pos-tol", g.posTolMm, "--grasp: position bound, MM (default 2, paper 003)")
      ->check(CLI::Range(0.0, 1000.0))
      ->needs(graspFlag);
  evalCmd->add_flag("--no-jaw-check{false}", g.detector.checkJaws, "--grasp: ggcnn takes the network's maps as they are (default: jaws checked on the height map)")
      ->needs(graspFlag);
  evalCmd->add_option("--opening-sigma", g.detector.openingSigmaMm, "--grasp: ggcnn weighs quality by the opening's agreement, MM (default 3, 0 off)")
      ->check(CLI::Range(0.0, 100.0))
      ->needs(graspFlag);
  evalCmd->add_option("--gripper-opening", g.detector.gripper.maxOpeningMm, "--grasp: widest gripper opening, MM (default 60)")
      ->check(CLI::Range(1.0, 1000.0))
      ->needs(graspFlag);
  for (auto* opt : jobOnly) graspFlag->excludes(opt);
  return evalCmd;
}

}  // namespace vgr::tools
