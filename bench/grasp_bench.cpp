// vgr-bench-grasp: the grasp detectors' time on one core (docs/grasp.md "Speed").
//   net      the grasp network alone (cv::dnn forward, DNN_BACKEND_OPENCV, CPU) on a
//            1 x 1 x 300 x 300 input, the usual GG-CNN input size (and on the detector's own
//            324 x 240 input), --reps times after one warm-up pass
//   ggcnn    the whole ggcnn detector on rendered 640 x 480 bin scenes (floor fit, input,
//            network, peaks)
//   analytic the analytic baseline on the same scenes
// OpenCV runs on one thread (cv::setNumThreads(1)); pin the process with taskset to keep it
// on one core. Per item: median wall time and median thread CPU time
// (CLOCK_THREAD_CPUTIME_ID) in ms; one final JSON line with the same figures.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <ctime>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/dnn.hpp>

#include "core/cli.hpp"
#include "sim/depth_render.hpp"
#include "sim/depth_scene.hpp"
#include "vision/grasp/grasp_detector.hpp"

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
  std::string name;
  std::vector<double> wall, cpu;
};

template <class F>
void measure(Timing& t, F&& f) {
  const auto w0 = std::chrono::steady_clock::now();
  const double c0 = threadCpuMs();
  f();
  t.cpu.push_back(threadCpuMs() - c0);
  t.wall.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count());
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-bench-grasp: grasp network and detectors, time on one core"};
  vgr::cli::showDefaults(app);
  std::string model = "models/grasp/ggcnn.onnx";
  int reps = 50, scenes = 20;
  app.add_option("--model", model, "the grasp network (ONNX)");
  app.add_option("--reps", reps, "forward passes per input size")->check(CLI::Range(1, 100000));
  app.add_option("--scenes", scenes, "rendered scenes per detector (0: the network alone, e.g. under callgrind)")
      ->check(CLI::Range(0, 100000));
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  cv::setNumThreads(1);

  {  // the detector's checks first: one clear line for a file that is not a grasp network
    vgr::vision::grasp::GraspDetectorOptions o;
    o.modelPath = model;
    if (auto d = vgr::vision::grasp::makeGraspDetector(o); !d) {
      std::fprintf(stderr, "%s\n", d.error().message.c_str());
      return 2;
    }
  }
  cv::dnn::Net net = cv::dnn::readNetFromONNX(model);
  net.setPreferableBackend(cv::dnn::DNN_BACKEND_OPENCV);
  net.setPreferableTarget(cv::dnn::DNN_TARGET_CPU);
  std::vector<Timing> rows;
  for (const cv::Size size : {cv::Size(300, 300), cv::Size(324, 240)}) {
    cv::Mat in(size, CV_32FC1);
    cv::randu(in, 0, 0.5);
    net.setInput(cv::dnn::blobFromImage(in));
    net.forward();  // warm-up: allocations for this size
    Timing t{fmt::format("net {}x{}", size.width, size.height), {}, {}};
    for (int i = 0; i < reps; ++i)
      measure(t, [&] {
        net.setInput(cv::dnn::blobFromImage(in));
        net.forward();
      });
    rows.push_back(t);
  }

  std::vector<vgr::vision::grasp::DepthFrame> frames;
  vgr::sim::DepthSceneOptions so;
  so.partsPerScene = 3;
  so.clutter = 10;
  so.seed = 4242;
  for (int i = 0; i < scenes; ++i) {
    so.part = i % 3 == 0 ? "bracket" : i % 3 == 1 ? "housing" : "lever";
    auto s = vgr::sim::renderDepthScene(so, static_cast<std::uint64_t>(i));
    if (!s) {
      std::fprintf(stderr, "scene %d: %s\n", i, s.error().message.c_str());
      return 1;
    }
    const auto& c = s->camera;
    frames.push_back({vgr::sim::depthToMm(s->depth, c.depthScaleMm), {c.width, c.height, c.fx, c.fy, c.cx, c.cy}, "scene"});
  }
  for (const char* name : {"ggcnn", "analytic"}) {
    if (frames.empty()) break;
    vgr::vision::grasp::GraspDetectorOptions o;
    o.detector = name;
    o.modelPath = model;
    auto det = vgr::vision::grasp::makeGraspDetector(o);
    if (!det) {
      std::fprintf(stderr, "%s\n", det.error().message.c_str());
      return 2;
    }
    (void)(*det)->detect(frames.front());  // warm-up
    Timing t{fmt::format("{} 640x480", name), {}, {}};
    int failed = 0;
    for (const auto& f : frames) measure(t, [&] { failed += !(*det)->detect(f); });
    if (failed) {
      std::fprintf(stderr, "%s failed on %d of %zu scenes\n", name, failed, frames.size());
      return 1;
    }
    rows.push_back(t);
  }

  std::string json = "{";
  for (const auto& r : rows) {
    std::printf("%-16s median %7.2f ms wall, %7.2f ms CPU (%zu runs)\n", r.name.c_str(), median(r.wall), median(r.cpu), r.wall.size());
    json += fmt::format("{}\"{}\":{{\"wall_ms\":{:.2f},\"cpu_ms\":{:.2f}}}", json.size() > 1 ? "," : "", r.name, median(r.wall), median(r.cpu));
  }
  std::printf("%s}\n", json.c_str());
  return 0;
}
