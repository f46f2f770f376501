// vgr-sim-camera: a GigE Vision camera on loopback serving rendered scenes with known
// ground truth. With no arguments it serves the camera of the embedded example cell
// (config/examples/sim-cell.yaml): address 127.0.0.1, serial VGR-SIM-0, seed 1.
#include <csignal>
#include <cstdio>
#include <thread>

#include <CLI/CLI.hpp>

#include "config/cell_config.hpp"
#include "core/log.hpp"
#include "sim/camera/emulator.hpp"

namespace {
volatile std::sig_atomic_t gStop = 0;
void onSignal(int) { gStop = 1; }
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-sim-camera: GigE Vision camera emulator serving rendered scenes with ground truth"};
  std::string configPath, address, serial, truthPath;
  long long seed = -1;
  app.add_option("--config", configPath, "cell config whose camera and sim sections to serve (default: the embedded sim-cell.yaml)");
  app.add_option("--address", address, "IPv4 address to serve on (default: the config's camera.address)");
  app.add_option("--serial", serial, "serial number (default: the config's sim.serial)");
  app.add_option("--seed", seed, "scene seed (default: the config's sim.seed)");
  app.add_option("--truth", truthPath, "append one JSON line of ground truth per served frame to this file");
  CLI11_PARSE(app, argc, argv);

  auto cfg = configPath.empty() ? vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "<embedded sim-cell.yaml>")
                                : vgr::config::loadCellConfig(configPath);
  if (!cfg) {
    std::fprintf(stderr, "vgr-sim-camera: %s\n", cfg.error().message.c_str());
    return 2;
  }
  if (seed >= 0) cfg->sim.seed = static_cast<std::uint64_t>(seed);
  vgr::sim::EmulatorOptions opts;
  opts.address = address.empty() ? (cfg->camera.address.empty() ? "127.0.0.1" : cfg->camera.address) : address;
  opts.serial = serial.empty() ? cfg->sim.serial : serial;
  opts.truthPath = truthPath;

  vgr::sim::CameraEmulator emulator(vgr::sim::SceneRenderer::fromCellConfig(*cfg), opts);
  if (auto r = emulator.start(); !r) {
    std::fprintf(stderr, "vgr-sim-camera: %s\n", r.error().message.c_str());
    return 1;
  }
  std::signal(SIGTERM, onSignal);
  std::signal(SIGINT, onSignal);
  std::printf("{\"event\":\"ready\",\"address\":\"%s\",\"serial\":\"%s\",\"seed\":%llu}\n", opts.address.c_str(),
              opts.serial.c_str(), static_cast<unsigned long long>(cfg->sim.seed));
  std::fflush(stdout);
  while (!gStop) std::this_thread::sleep_for(std::chrono::milliseconds(50));
  vgr::log::info("sim", "camera emulator stopping after {} frames", emulator.framesServed());
  return 0;
}
