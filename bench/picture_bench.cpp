// vgr-bench-picture: what the page's render thread spends on one live picture (docs/3d.md
// "The page's depth picture"): the 2D picture (vision/overlay.hpp drawOverlay on an 8-bit
// gray frame + JPEG) next to a 3D cycle's picture (colourDepth + drawOverlay with a 3D part
// and the colour bar + JPEG), on the same rendered 640 x 480 bin scenes (the 2D picture on
// the scene's depth squeezed to 8 bits: same size, same content). JPEG quality 85 as the
// page. OpenCV on one thread; pin with taskset. Per picture: median wall and thread CPU time
// (CLOCK_THREAD_CPUTIME_ID) in ms, and the CPU ratio; one final JSON line.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "core/cli.hpp"
#include "sim/depth_render.hpp"
#include "sim/depth_scene.hpp"
#include "vision/overlay.hpp"

namespace {

double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

struct Timing {
  std::vector<double> wall, cpu;
  template <class F>
  void measure(F&& f) {
    const auto w0 = std::chrono::steady_clock::now();
    const double c0 = threadCpuMs();
    f();
    cpu.push_back(threadCpuMs() - c0);
    wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count());
  }
};

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-bench-picture: the page's live picture, 2D vs a 3D cycle's depth picture"};
  vgr::cli::showDefaults(app);
  int scenes = 10, reps = 20;
  app.add_option("--scenes", scenes, "rendered 640 x 480 bin scenes")->check(CLI::Range(1, 1000));
  app.add_option("--reps", reps, "pictures per scene and kind")->check(CLI::Range(1, 100000));
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  cv::setNumThreads(1);

  vgr::sim::DepthSceneOptions so;
  so.part = "housing";
  so.clutter = 4;
  so.seed = 7;
  Timing flat, depth;
  std::vector<uchar> jpeg;
  cv::Mat colours;
  for (int i = 0; i < scenes; ++i) {
    auto s = vgr::sim::renderDepthScene(so, static_cast<std::uint64_t>(i));
    if (!s) {
      std::fprintf(stderr, "scene %d: %s\n", i, s.error().message.c_str());
      return 1;
    }
    const auto& c = s->camera;
    const cv::Mat mm = vgr::sim::depthToMm(s->depth, c.depthScaleMm);
    cv::Mat gray;
    s->depth.convertTo(gray, CV_8U, 255.0 / 12000);  // 0..1200 mm -> 0..255
    const vgr::DepthIntrinsics k{c.fx, c.fy, c.cx, c.cy, c.width, c.height};
    vgr::vision::OverlayFrame f;
    f.caption = vgr::vision::cycleCaption(static_cast<std::uint32_t>(i + 1), 1, vgr::Status::Ok, s->parts.size());
    for (const auto& p : s->parts) f.parts.push_back(vgr::vision::overlayPart3d(p.pose, k, 0.9));
    vgr::vision::OverlayFrame f2 = f;
    for (auto& p : f2.parts) p.axes3d = false;
    for (int r = 0; r < reps; ++r) {
      flat.measure([&] { cv::imencode(".jpg", vgr::vision::drawOverlay(gray, f2), jpeg, {cv::IMWRITE_JPEG_QUALITY, 85}); });
      depth.measure([&] {
        vgr::vision::OverlayFrame g = f;
        g.depthRange = vgr::vision::colourDepth(mm, colours);
        cv::imencode(".jpg", vgr::vision::drawOverlay(colours, g), jpeg, {cv::IMWRITE_JPEG_QUALITY, 85});
      });
    }
  }
  const double ratio = median(depth.cpu) / median(flat.cpu);
  std::printf("2D picture     median %6.2f ms wall, %6.2f ms CPU (%zu pictures)\n", median(flat.wall), median(flat.cpu),
              flat.cpu.size());
  std::printf("depth picture  median %6.2f ms wall, %6.2f ms CPU (%zu pictures); CPU ratio depth / 2D %.2f\n",
              median(depth.wall), median(depth.cpu), depth.cpu.size(), ratio);
  std::printf("{\"flat\":{\"wall_ms\":%.2f,\"cpu_ms\":%.2f},\"depth\":{\"wall_ms\":%.2f,\"cpu_ms\":%.2f},\"cpu_ratio\":%.2f}\n",
              median(flat.wall), median(flat.cpu), median(depth.wall), median(depth.cpu), ratio);
  return 0;
}
