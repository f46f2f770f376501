// vgr: the offline tool. Subcommands:
//   vgr demo [--cycles N]     run the simulated cell end to end (docs/demo.md)
//   vgr check --config FILE   validate a cell config
//   vgr cameras [--json]      list the GigE Vision cameras on the network (docs/cameras.md)
//   vgr grab --camera ID ...  trigger N frames, report errors and latency (docs/cameras.md)
//   vgr calibrate intrinsics|handeye|synth ...   calibration (docs/calibration.md)
//   vgr sim render | teach | locate | eval   localization datasets, jobs, runs (docs/localization.md)
#include <cstdio>
#include <string>

#include <CLI/CLI.hpp>

#include "config/cell_config.hpp"
#include "core/version.hpp"
#include "daemon/calibrate.hpp"
#include "daemon/demo.hpp"
#include "daemon/grab.hpp"
#include "daemon/locate_cli.hpp"

int main(int argc, char** argv) {
  CLI::App app{"vgr: vision-guided robotics tool"};
  app.set_version_flag("--version", std::string("vgr ") + vgr::buildVersion());
  app.require_subcommand(1);

  vgr::daemon::DemoOptions demo;
  auto* demoCmd = app.add_subcommand("demo", "run the simulated cell (camera emulator, vgrd, PLC and robot simulators) for N cycles");
  demoCmd->add_option("--cycles", demo.cycles, "number of PLC-triggered cycles")->check(CLI::Range(1, 1000000));
  demoCmd->add_option("--config", demo.configPath, "cell config (default: the embedded config/examples/sim-cell.yaml)");
  demoCmd->add_option("--bin-dir", demo.binDir, "folder of vgrd and the simulators (default: next to vgr)");
  demoCmd->add_option("--work-dir", demo.workDir, "folder for logs, journal and truth (default: a new /tmp/vgr-demo-*)");
  demoCmd->add_option("--interval-ms", demo.intervalMs, "PLC pause between cycles")->check(CLI::Range(0, 60000));
  demoCmd->add_option("--seed", demo.seed, "scene seed (default: the config's sim.seed)");
  demoCmd->add_flag("--quiet", demo.quiet, "only the summary lines");
  demoCmd->add_option("--scene", demo.scene, "with --method: part (textured plate, default) or multi (height levels)");
  demoCmd->add_option("--method", demo.method, "run a job of this method taught on the textured part (moments, hu, sift, orb-ransac, orb-prosac, orb-adk, contour-weighted, shape)");

  std::string checkPath;
  auto* checkCmd = app.add_subcommand("check", "validate a cell config; prints file:line and key on error");
  checkCmd->add_option("--config", checkPath, "cell config")->required();

  bool camerasJson = false;
  auto* camerasCmd = app.add_subcommand("cameras", "list the cameras discovery finds (serial, model, address)");
  camerasCmd->add_flag("--json", camerasJson, "one JSON array");

  vgr::daemon::GrabOptions grab;
  auto* grabCmd = app.add_subcommand("grab", "trigger N frames; report frames, typed errors and trigger->frame latency");
  grabCmd->add_option("--camera", grab.camera, "IPv4 address, serial number or DeviceUserID");
  grabCmd->add_option("--config", grab.configPath, "cell config whose camera section gives the features");
  grabCmd->add_option("--count", grab.count, "number of triggers")->check(CLI::Range(1, 10000000));
  grabCmd->add_option("--trigger", grab.trigger, "software, hardware or free_run (default: the config's, else software)");
  grabCmd->add_option("--pixel-format", grab.pixelFormat, "Mono8, Mono10, Mono12, Mono16, BayerRG8, ...");
  grabCmd->add_option("--packet-size", grab.packetSize, "GigE packet size in bytes (0 negotiates)")->check(CLI::Range(0, 65000));
  grabCmd->add_option("--retries", grab.retries, "re-triggers after a lost frame within the deadline")->check(CLI::Range(0, 10));
  grabCmd->add_option("--timeout-ms", grab.timeoutMs, "trigger -> frame timeout per attempt")->check(CLI::Range(50, 60000));
  grabCmd->add_option("--deadline-ms", grab.deadlineMs, "trigger -> frame deadline incl. re-triggers (default: cycle_deadline_ms)")->check(CLI::Range(50, 600000));
  grabCmd->add_option("--interval-ms", grab.intervalMs, "pause between triggers")->check(CLI::Range(0, 60000));
  grabCmd->add_option("--save", grab.saveFolder, "write every frame received to this folder as frame_<frame id>.png");
  grabCmd->add_flag("--json", grab.json, "JSON output; the last line is {\"frames\",\"ok\",\"errors\",\"p50_ms\",\"p99_ms\"}");

  // vgr calibrate ... (docs/calibration.md)
  auto* calCmd = app.add_subcommand("calibrate", "camera intrinsics, hand-eye, synthetic calibration data");
  calCmd->require_subcommand(1);
  auto addPattern = [](CLI::App* c, vgr::daemon::CalibPatternOptions& p) {
    c->add_option("--pattern", p.pattern, "chessboard, circles (symmetric grid) or charuco");
    c->add_option("--cols", p.cols, "inner corners (chessboard, charuco: squares - 1) / circles per row");
    c->add_option("--rows", p.rows, "inner corners (chessboard, charuco: squares - 1) / circles per column");
    c->add_option("--square", p.squareMm, "square size / circle spacing, mm");
    c->add_option("--marker", p.markerMm, "charuco: ArUco marker side, mm (default 0.75 x square)");
    c->add_option("--dict", p.dictionary, "charuco: ArUco dictionary, e.g. DICT_5X5_100 (default), DICT_4X4_50, DICT_6X6_250");
  };
  vgr::daemon::CalibIntrinsicsOptions calIntr;
  auto* calIntrCmd = calCmd->add_subcommand("intrinsics", "camera matrix and distortion from plate images");
  calIntrCmd->add_option("--images", calIntr.images, "glob of the plate images, e.g. 'calib/*.png'")->required();
  addPattern(calIntrCmd, calIntr.pattern);
  calIntrCmd->add_option("--out", calIntr.out, "OpenCV FileStorage YAML to write");
  calIntrCmd->add_flag("--no-tangential", calIntr.noTangential,
                       "hold the tangential distortion p1, p2 at 0 (only for a lens known to have none)");
  calIntrCmd->add_flag("--json", calIntr.json, "end with one JSON line (rms_px, fx, fy, cx, cy, views_used, ...)");
  vgr::daemon::CalibHandEyeOptions calHe;
  auto* calHeCmd = calCmd->add_subcommand("handeye", "hand-eye from a folder of plate images + poses.txt");
  calHeCmd->add_option("--folder", calHe.folder, "folder with poses.txt and the images it names")->required();
  calHeCmd->add_option("--intrinsics", calHe.intrinsics, "intrinsics.yaml from 'vgr calibrate intrinsics'")->required();
  calHeCmd->add_option("--configuration", calHe.configuration, "eye-in-hand, eye-to-hand or auto");
  addPattern(calHeCmd, calHe.pattern);
  calHeCmd->add_option("--out", calHe.out, "handeye.yaml to write");
  calHeCmd->add_option("--truth", calHe.truth, "truth.yaml of a synthetic set: print each method's error");
  calHeCmd->add_flag("--json", calHe.json, "end with one JSON line");
  vgr::daemon::CalibPlaneOptions calPl;
  auto* calPlCmd = calCmd->add_subcommand("plane", "work plane from a plate on the conveyor or robot-touched points");
  calPlCmd->add_option("--image", calPl.image, "image of a plate lying on the conveyor");
  calPlCmd->add_option("--intrinsics", calPl.intrinsics, "intrinsics.yaml (with --image)");
  calPlCmd->add_option("--handeye", calPl.handeye, "eye-to-hand handeye.yaml (with --image)");
  calPlCmd->add_option("--thickness", calPl.thicknessMm, "plate thickness, mm (with --image)");
  calPlCmd->add_option("--points", calPl.points, "file of robot-touched points, 'x y z' mm per line");
  addPattern(calPlCmd, calPl.pattern);
  calPlCmd->add_option("--out", calPl.out, "plane.yaml to write");
  calPlCmd->add_flag("--json", calPl.json, "end with one JSON line");
  vgr::daemon::CalibSynthOptions calSyn;
  auto* calSynCmd = calCmd->add_subcommand("synth", "render a synthetic calibration set with ground truth");
  calSynCmd->add_option("--kind", calSyn.kind, "intrinsics, handeye or cell (all three sets for a cell's camera)");
  calSynCmd->add_option("--cell", calSyn.cellConfig, "cell config for --kind cell (default: the embedded sim cell)");
  calSynCmd->add_option("--out", calSyn.out, "folder to write")->required();
  calSynCmd->add_option("--configuration", calSyn.configuration, "eye-in-hand or eye-to-hand (handeye)");
  calSynCmd->add_option("--pose-format", calSyn.poseFormat, "abb, fanuc or ur (handeye)");
  addPattern(calSynCmd, calSyn.pattern);
  calSynCmd->add_option("--views", calSyn.views, "number of views")->check(CLI::Range(1, 1000));
  calSynCmd->add_option("--seed", calSyn.seed, "random seed");
  calSynCmd->add_option("--robot-noise-mm", calSyn.robotNoiseMm, "robot position noise, mm per axis");
  calSynCmd->add_option("--robot-noise-deg", calSyn.robotNoiseDeg, "robot rotation noise, deg per axis");
  calSynCmd->add_option("--max-tilt", calSyn.maxTiltDeg, "largest plate tilt, deg");
  calSynCmd->add_option("--distance", calSyn.distanceMm, "camera-plate distance, mm");
  calSynCmd->add_option("--partial", calSyn.partialShare, "share of views with the plate partly outside the image (charuco)")
      ->check(CLI::Range(0.0, 1.0));

  vgr::daemon::LocateCommands locateCmds(app);  // sim render, teach, locate, eval
  CLI11_PARSE(app, argc, argv);
  if (const int rc = locateCmds.run(); rc >= 0) return rc;

  if (*calIntrCmd) return vgr::daemon::runCalibrateIntrinsics(calIntr);
  if (*calHeCmd) return vgr::daemon::runCalibrateHandEye(calHe);
  if (*calSynCmd) return vgr::daemon::runCalibrateSynth(calSyn);
  if (*calPlCmd) return vgr::daemon::runCalibratePlane(calPl);

  if (*camerasCmd) return vgr::daemon::runCameras(camerasJson);
  if (*grabCmd) return vgr::daemon::runGrab(grab);

  if (*demoCmd) return vgr::daemon::runDemo(demo);
  if (*checkCmd) {
    auto cfg = vgr::config::loadCellConfig(checkPath);
    if (!cfg) {
      std::fprintf(stderr, "%s\n", cfg.error().message.c_str());
      return 2;
    }
    std::printf("%s: ok\n", checkPath.c_str());
    return 0;
  }
  return 0;
}
