// vgr-bench-camera: trigger->frame latency and sustained frame rate of the real Aravis
// driver against vgr-sim-camera on loopback (docs/cameras.md, "Benchmark").
//   software trigger: N triggers, one at a time; latency = triggerAndWait() wall time
//   free-run: frames delivered per second over a fixed window at the emulator's --fps
// The emulator serves a pre-rendered image (--images) so that the numbers are the GigE
// path's, not the scene renderer's (~90 ms per 5 MP frame); --render measures with it.
#include <unistd.h>

#include <algorithm>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "core/child_process.hpp"
#include "drivers/camera.hpp"
#include "sim/scene.hpp"

namespace {
using Clock = std::chrono::steady_clock;
using std::chrono::milliseconds;

double pct(std::vector<double> v, double p) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  const auto i = static_cast<std::size_t>(std::max(0.0, std::ceil(p / 100.0 * v.size()) - 1));
  return v[std::min(i, v.size() - 1)];
}
}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-bench-camera: trigger->frame latency and frame rate over loopback GigE Vision"};
  vgr::cli::showDefaults(app);
  int width = 2448, height = 2048, triggers = 300, packetSize = 16384, seconds = 5;
  double fps = 1000;
  bool render = false;
  std::string pixelFormat = "Mono8";
  app.add_option("--width", width)->check(CLI::Range(64, 2448));
  app.add_option("--height", height)->check(CLI::Range(64, 2048));
  app.add_option("--triggers", triggers, "software triggers for the latency run");
  app.add_option("--packet-size", packetSize, "GVSP packet size, bytes");
  app.add_option("--seconds", seconds, "free-run window");
  app.add_option("--fps", fps, "emulator free-run rate (an upper bound)");
  app.add_option("--pixel-format", pixelFormat, "Mono8 or Mono16");
  app.add_flag("--render", render, "serve rendered scenes instead of a pre-rendered image");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;

  namespace fs = std::filesystem;
  const std::string bin = fs::canonical("/proc/self/exe").parent_path().string();
  const fs::path dir = fs::temp_directory_path() / ("vgr-bench-camera-" + std::to_string(::getpid()));
  fs::create_directories(dir);
  auto cell = *vgr::config::parseCellConfig(vgr::config::embeddedSimCellYaml(), "embedded");
  cell.sim.width = width;
  cell.sim.height = height;
  std::vector<std::string> emu = {bin + "/vgr-sim-camera", "--width", std::to_string(width), "--height", std::to_string(height),
                                  "--fps", std::to_string(fps)};
  if (!render) {
    cv::Mat img;
    vgr::sim::SceneRenderer::fromCellConfig(cell).render(1, img);
    cv::imwrite((dir / "scene.png").string(), img);
    emu.insert(emu.end(), {"--images", dir.string()});
  }
  auto proc = vgr::ChildProcess::spawn(emu, (dir / "camera.log").string());
  if (!proc || !proc->waitForLine("\"ready\"", milliseconds(10000))) {
    std::fprintf(stderr, "vgr-bench-camera: the emulator did not start (see %s)\n", (dir / "camera.log").c_str());
    return 1;
  }

  auto run = [&](vgr::config::TriggerMode mode) -> std::unique_ptr<vgr::drivers::Camera> {
    auto c = cell.camera;
    c.trigger = mode;
    c.packetSize = packetSize;
    c.pixelFormat = pixelFormat;
    auto cam = vgr::drivers::makeCamera(c);
    if (!cam || !(*cam)->open() || !(*cam)->start()) return nullptr;
    return std::move(*cam);
  };

  // 1. Software trigger -> frame latency.
  auto cam = run(vgr::config::TriggerMode::Software);
  if (!cam) {
    std::fprintf(stderr, "vgr-bench-camera: cannot open the camera\n");
    return 1;
  }
  vgr::drivers::Frame frame;
  std::vector<double> lat;
  int lost = 0;
  const auto t0 = Clock::now();
  for (int i = 0; i < triggers; ++i) {
    const auto a = Clock::now();
    if (cam->triggerAndWait(frame, milliseconds(2000)))
      lat.push_back(std::chrono::duration<double, std::milli>(Clock::now() - a).count());
    else
      ++lost;
  }
  const double swSeconds = std::chrono::duration<double>(Clock::now() - t0).count();
  cam.reset();

  // 2. Free-run: sustained frames per second delivered to the caller.
  cam = run(vgr::config::TriggerMode::FreeRun);
  int frames = 0;
  const auto f0 = Clock::now();
  while (cam && Clock::now() - f0 < std::chrono::seconds(seconds))
    if (cam->triggerAndWait(frame, milliseconds(2000))) ++frames;
  const double frSeconds = std::chrono::duration<double>(Clock::now() - f0).count();
  const auto st = cam ? cam->stats() : vgr::drivers::CameraStats{};
  cam.reset();
  proc->stop();
  std::error_code ec;
  fs::remove_all(dir, ec);

  std::printf("{\"width\":%d,\"height\":%d,\"pixel_format\":\"%s\",\"packet_size\":%d,\"source\":\"%s\","
              "\"triggers\":%d,\"lost\":%d,\"p50_ms\":%.2f,\"p90_ms\":%.2f,\"p99_ms\":%.2f,\"max_ms\":%.2f,"
              "\"triggered_fps\":%.1f,\"free_run_fps\":%.1f,\"free_run_underruns\":%llu}\n",
              width, height, pixelFormat.c_str(), packetSize, render ? "render" : "image", triggers, lost, pct(lat, 50),
              pct(lat, 90), pct(lat, 99), pct(lat, 100), lat.size() / swSeconds, frames / frSeconds,
              static_cast<unsigned long long>(st.underruns));
  return 0;
}
