// vgr-sim-camera: GigE Vision cameras on loopback serving rendered scenes with known ground
// truth (or the images of a folder): the config's `sim.scene` (plate, part or multi; see
// sim/cell_scenes.hpp). --depth DIR: a depth camera (Coord3D_C16 with the SFNC Scan3d
// features) serving a 3D data set, truth per frame with --truth (sim/camera/emulator.hpp). With no arguments it serves the camera of the embedded
// example cell (config/examples/sim-cell.yaml): address 127.0.0.1, serial VGR-SIM-0, seed 1.
// Several cameras: --camera SERIAL@ADDRESS, repeated (one address each; camera i renders
// with seed + i). SIGUSR1 = one edge on every camera's Line0 (simulated hardware trigger).
// SIGUSR2 toggles the GVSP packet loss between --loss and --loss-burst (fault injection).
// Commissioning (docs/commissioning.md): --still (the part does not move; the noise still
// changes per frame) and --camera-shift X,Y[,Z[,RZ]] (mm, deg: the camera knocked away
// from where its calibration says it is) override the config's sim.still / sim.camera_shift.
#include <cmath>
#include <csignal>
#include <cstdio>
#include <memory>
#include <thread>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"

#include "config/cell_config.hpp"
#include "core/log.hpp"
#include "sim/camera/emulator.hpp"

namespace {
volatile std::sig_atomic_t gStop = 0;
volatile std::sig_atomic_t gPulses = 0;
volatile std::sig_atomic_t gLossToggles = 0;
void onSignal(int) { gStop = 1; }
void onPulse(int) { gPulses = gPulses + 1; }
void onLossToggle(int) { gLossToggles = gLossToggles + 1; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-sim-camera: GigE Vision camera emulator serving rendered scenes with ground truth"};
  vgr::cli::showDefaults(app);
  std::string configPath, address, serial, truthPath, imagesFolder, scene;
  std::vector<std::string> cameraSpecs;
  long long seed = -1;
  int width = 0, height = 0;
  double loss = 0.0, lossBurst = 0.05, fps = 25.0;
  bool still = false;
  std::string shift;
  int emptyEvery = 0;
  app.add_option("--config", configPath, "cell config whose camera and sim sections to serve (default: the embedded sim-cell.yaml)");
  app.add_option("--address", address, "IPv4 address to serve on (default: the config's camera.address)");
  app.add_option("--serial", serial, "serial number (default: the config's sim.serial)");
  app.add_option("--camera", cameraSpecs, "SERIAL@ADDRESS of one more camera (repeatable; replaces --address/--serial)");
  app.add_option("--seed", seed, "scene seed (default: the config's sim.seed)");
  app.add_option("--width", width, "sensor width in px (default: the config's sim.width)")->check(CLI::Range(64, 2448));
  app.add_option("--height", height, "sensor height in px (default: the config's sim.height)")->check(CLI::Range(64, 2048));
  app.add_option("--loss", loss, "probability that a GVSP packet is dropped, e.g. 1e-4")->check(CLI::Range(0.0, 1.0));
  app.add_option("--loss-burst", lossBurst, "packet loss while a burst is on (SIGUSR2 toggles it)")->check(CLI::Range(0.0, 1.0));
  app.add_option("--fps", fps, "free-run frame rate")->check(CLI::Range(0.1, 1000.0));
  app.add_option("--scene", scene, "what to show: plate, part (textured) or multi (height levels) (default: the config's sim.scene)")
      ->check(CLI::IsMember({"plate", "part", "multi"}));
  app.add_option("--images", imagesFolder, "serve the images of this folder (name order, looping) instead of scenes");
  std::string depthDataset, depthUnit = "Millimeter";
  app.add_option("--depth", depthDataset,
                 "be a depth camera (Coord3D_C16, Scan3d features) serving this 3D data set (camera.yaml, images/, truth.csv)");
  app.add_option("--depth-unit", depthUnit, "the Scan3dDistanceUnit served (tests of a camera the driver refuses)")
      ->check(CLI::IsMember({"Millimeter", "Inch", "Pixel"}));
  app.add_flag("--still", still, "every frame shows frame 1's scene (only the noise changes): sim.still");
  app.add_option("--camera-shift", shift, "X,Y[,Z[,RZ]]: render through a camera moved by this many mm (deg): sim.camera_shift");
  app.add_option("--empty-every", emptyEvery, "every N-th frame shows the empty belt (no part): a cell where every N-th cycle fails")
      ->check(CLI::Range(0, 1000000));
  app.add_option("--truth", truthPath, "append one JSON line of ground truth per served frame to this file (first camera)");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;

  auto cfg = configPath.empty() ? vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "<embedded sim-cell.yaml>")
                                : vgr::config::loadCellConfig(configPath);
  if (!cfg) {
    std::fprintf(stderr, "vgr-sim-camera: %s\n", cfg.error().message.c_str());
    return 2;
  }
  if (seed >= 0) cfg->sim.seed = static_cast<std::uint64_t>(seed);
  if (width > 0) cfg->sim.width = width;
  if (height > 0) cfg->sim.height = height;
  if (!scene.empty()) cfg->sim.scene = scene;
  if (still) cfg->sim.still = true;
  if (!shift.empty()) {
    double v[4] = {0, 0, 0, 0};
    int n = 0;
    char tail = 0;
    n = std::sscanf(shift.c_str(), "%lf,%lf,%lf,%lf%c", &v[0], &v[1], &v[2], &v[3], &tail);
    if (n < 2 || n > 4 || std::abs(v[0]) > 100 || std::abs(v[1]) > 100 || std::abs(v[2]) > 100 || std::abs(v[3]) > 10) {
      std::fprintf(stderr, "vgr-sim-camera: --camera-shift '%s': expected X,Y[,Z[,RZ]] (mm within 100, deg within 10)\n",
                   shift.c_str());
      return 2;
    }
    cfg->sim.shiftXMm = v[0];
    cfg->sim.shiftYMm = v[1];
    cfg->sim.shiftZMm = v[2];
    cfg->sim.shiftRzDeg = v[3];
  }

  std::vector<vgr::sim::EmulatorOptions> cams;
  if (cameraSpecs.empty()) {
    vgr::sim::EmulatorOptions o;
    o.address = address.empty() ? (cfg->camera.address.empty() ? "127.0.0.1" : cfg->camera.address) : address;
    o.serial = serial.empty() ? cfg->sim.serial : serial;
    cams.push_back(o);
  }
  for (const auto& spec : cameraSpecs) {
    const auto at = spec.find('@');
    if (at == std::string::npos || at == 0 || at + 1 == spec.size()) {
      std::fprintf(stderr, "vgr-sim-camera: --camera '%s': expected SERIAL@ADDRESS\n", spec.c_str());
      return 2;
    }
    vgr::sim::EmulatorOptions o;
    o.serial = spec.substr(0, at);
    o.address = spec.substr(at + 1);
    cams.push_back(o);
  }

  std::vector<std::unique_ptr<vgr::sim::CameraEmulator>> emulators;
  for (std::size_t i = 0; i < cams.size(); ++i) {
    auto& o = cams[i];
    o.lossRatio = loss;
    o.fps = fps;
    o.imagesFolder = imagesFolder;
    o.depthDataset = depthDataset;
    o.depthUnit = depthUnit;
    o.emptyEvery = emptyEvery;
    if (i == 0) o.truthPath = truthPath;
    auto cell = *cfg;
    cell.sim.seed = cfg->sim.seed + i;
    emulators.push_back(std::make_unique<vgr::sim::CameraEmulator>(vgr::sim::CellScenes(cell), o));
    if (auto r = emulators.back()->start(); !r) {
      std::fprintf(stderr, "vgr-sim-camera: %s\n", r.error().message.c_str());
      return 1;
    }
  }
  std::signal(SIGTERM, onSignal);
  std::signal(SIGINT, onSignal);
  std::signal(SIGUSR1, onPulse);
  std::signal(SIGUSR2, onLossToggle);
  std::printf("{\"event\":\"ready\",\"address\":\"%s\",\"serial\":\"%s\",\"seed\":%llu,\"cameras\":%zu}\n",
              cams[0].address.c_str(), cams[0].serial.c_str(), static_cast<unsigned long long>(cfg->sim.seed), cams.size());
  std::fflush(stdout);
  int handled = 0, togglesHandled = 0;
  bool burst = false;
  while (!gStop) {
    std::this_thread::sleep_for(std::chrono::milliseconds(1));
    while (handled != gPulses) {
      ++handled;
      for (auto& e : emulators) e->pulseLine();
    }
    while (togglesHandled != gLossToggles) {
      ++togglesHandled;
      burst = !burst;
      for (auto& e : emulators) e->setLossRatio(burst ? lossBurst : loss);
    }
  }
  for (std::size_t i = 0; i < emulators.size(); ++i)
    vgr::log::info("sim", "camera emulator {} stopping after {} frames", cams[i].serial, emulators[i]->framesServed());
  return 0;
}
