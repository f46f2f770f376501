// vgr-bench-cloud: the 3D locator (vision/cloud/locator3d.hpp, paper 004) on depth scenes
// rendered in-process (sim/depth_scene.hpp), one part kind per run: success at 2 mm / 2 deg,
// errors, misses, false poses, retries and the time per image (wall and thread CPU time,
// median and max). Figures and commands: docs/3d.md "Measured".
//   --preset open3d   Open3D's tutorial defaults on the whole scene (FPFH + Open3D's RANSAC,
//                     100000 iterations, confidence 0.999, one model copy) next to ours
// Pin it to one core (taskset -c 0) for the one-core figure; --threads bounds OpenMP.
#include <time.h>

#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

#include "sim/depth_parts.hpp"
#include "sim/depth_scene.hpp"
#include "vision/cloud/eval3d.hpp"
#include "vision/cloud/locator3d.hpp"

namespace {

double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec / 1e6;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace vgr;
  CLI::App app{"vgr-bench-cloud: the 3D locator on rendered depth scenes (docs/3d.md)"};
  sim::DepthSceneOptions scene;
  int scenes = 50;
  int first = 0;
  std::string preset = "vgr";
  Search3dParams p;
  bool verbose = false;
  app.add_option("--part", scene.part, "bracket, housing or lever");
  app.add_option("--scenes", scenes, "scenes")->check(CLI::Range(1, 100000));
  app.add_option("--first", first, "index of the first scene")->check(CLI::Range(0, 100000000));
  app.add_option("--seed", scene.seed);
  app.add_option("--parts", scene.partsPerScene)->check(CLI::Range(0, 8));
  app.add_option("--clutter", scene.clutter)->check(CLI::Range(0, 32));
  app.add_option("--empty-ratio", scene.emptyRatio)->check(CLI::Range(0.0, 1.0));
  app.add_option("--occlusion", scene.occlusion)->check(CLI::Range(0.0, 0.95));
  app.add_option("--tilt-max", scene.tiltMaxDeg)->check(CLI::Range(0.0, 60.0));
  app.add_option("--noise", scene.sensor.noiseMmAt500)->check(CLI::Range(0.0, 10.0));
  app.add_option("--dropout", scene.sensor.dropout)->check(CLI::Range(0.0, 0.9));
  app.add_option("--preset", preset, "vgr (our job defaults) or open3d (Open3D's tutorial defaults)")->check(CLI::IsMember({"vgr", "open3d"}));
  app.add_option("--threads", p.threads)->check(CLI::Range(1, 64));
  app.add_option("--voxel", p.voxelMm);
  app.add_option("--n-r", p.nRotations);
  app.add_option("--f-l", p.fLow);
  app.add_option("--f-h", p.fHigh);
  app.add_option("--max-parts", p.maxParts);
  app.add_option("--ransac-iterations", p.ransacIterations);
  app.add_option("--ransac-confidence", p.ransacConfidence);
  app.add_option("--max-contradiction", p.maxContradiction);
  app.add_option("--cluster-mm", p.clusterMm, "DBSCAN radius of the scene clusters, 0 = whole scene");
  app.add_option("--feature-neighbours", p.featureNeighbours, "model features per scene point");
  app.add_option("--feature-radius", p.featureRadiusMm);
  app.add_option("--hypotheses", p.hypothesesPerCopy);
  app.add_option("--max-below-plane", p.maxBelowPlaneMm);
  app.add_option("--camera-tilt-max", scene.cameraTiltMaxDeg)->check(CLI::Range(0.0, 30.0));
  std::vector<double> roi;
  app.add_option("--roi", roi, "x_min,x_max,y_min,y_max,z_min,z_max (mm, camera frame)")->delimiter(',')->expected(6);
  int width = 640;
  app.add_option("--width", width, "image width, px (height 3/4 of it, focal 800 px x width / 640)")->check(CLI::Range(64, 4096));
  app.add_flag("--verbose", verbose, "one line per scene");
  CLI11_PARSE(app, argc, argv);
  scene.camera.width = width;
  scene.camera.height = width * 3 / 4;
  scene.camera.fx = scene.camera.fy = 800.0 * width / 640;
  scene.camera.cx = (scene.camera.width - 1) / 2.0;
  scene.camera.cy = (scene.camera.height - 1) / 2.0;
  if (roi.size() == 6) p.roi = {roi[0], roi[1], roi[2], roi[3], roi[4], roi[5]};
  if (preset == "open3d") {
    // Open3D's global registration tutorial on the whole scene (the former pipeline, paper
    // 004 Sec. 3.2 as written): FPFH of the whole model (radius 5 voxels, 100 neighbours),
    // Open3D's RANSAC on the feature matches (100000 iterations, confidence 0.999, distance
    // 1.5 voxels, edge length 0.9), one model copy; then our ICP and checks.
    p.clusterMm = 0;
    p.modelViews = 0;
    p.featureRadiusMm = 5 * p.voxelMm;
    p.ransacIterations = 100000;
    p.ransacConfidence = 0.999;
    p.nRotations = 1;
  }

  auto part = sim::depthPart(scene.part);
  if (!part) {
    std::fprintf(stderr, "%s\n", part.error().message.c_str());
    return 2;
  }
  vision::PlyCloud model;
  std::vector<std::array<double, 3>> addPoints;
  for (const auto& s : sim::sampleSurface(*part, 1.0)) {
    model.points.push_back({s.x, s.y, s.z});
    model.normals.push_back({s.nx, s.ny, s.nz});
  }
  for (std::size_t i = 0; i < model.points.size(); i += 4) addPoints.push_back(model.points[i]);
  auto locator = vision::cloud::makeLocator3d(model, Pose{}, p);
  if (!locator) {
    std::fprintf(stderr, "%s\n", locator.error().message.c_str());
    return 2;
  }
  vision::cloud::Eval3dAccumulator acc(addPoints, {});
  const auto& cam = scene.camera;
  const vision::cloud::DepthIntrinsics k{cam.fx, cam.fy, cam.cx, cam.cy, cam.width, cam.height};
  for (int i = first; i < first + scenes; ++i) {
    auto s = sim::renderDepthScene(scene, static_cast<std::uint64_t>(i));
    if (!s) {
      std::fprintf(stderr, "%s\n", s.error().message.c_str());
      return 2;
    }
    const cv::Mat mm = sim::depthToMm(s->depth, cam.depthScaleMm);
    if (std::getenv("VGR_CLOUD_TRACE")) {
      for (const auto& t : s->parts)
        std::fprintf(stderr, "scene %d truth %.1f %.1f %.1f q %.3f %.3f %.3f %.3f face %s\n", i, t.pose.x, t.pose.y, t.pose.z, t.pose.qw,
                     t.pose.qx, t.pose.qy, t.pose.qz, t.face.c_str());
      if (!s->parts.empty()) {
        const auto& t = s->parts.front().pose;
        setenv("VGR_CLOUD_TRUTH", fmt::format("{} {} {} {} {} {} {}", t.x, t.y, t.z, t.qw, t.qx, t.qy, t.qz).c_str(), 1);
      }
    }
    const double c0 = threadCpuMs();
    const auto w0 = std::chrono::steady_clock::now();
    auto r = (*locator)->locate(mm, k);
    const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count();
    const double cpu = threadCpuMs() - c0;
    if (!r) {
      std::fprintf(stderr, "scene %d: %s\n", i, r.error().message.c_str());
      return 1;
    }
    std::vector<Pose> truth;
    for (const auto& t : s->parts) truth.push_back(t.pose);
    acc.add(truth, *r, wall, cpu);
    if (verbose) {
      std::printf("scene %4d: %-19s parts %zu/%zu cand %2d pts %5d  %.0f ms (cpu %.0f)", i,
                  std::string(vision::cloud::outcomeName(r->outcome)).c_str(), r->parts.size(), truth.size(), r->candidates,
                  r->scenePoints, wall, cpu);
      for (const auto& pr : acc.lastPairs()) {
        if (pr.found >= 0) {
          const auto& f = r->parts[static_cast<std::size_t>(pr.found)];
          std::printf("  [f %.2f c %.2f%s", f.fitness, f.contradiction, f.refined ? " R" : "");
          if (pr.truth >= 0) std::printf(" e %.2fmm %.2fdeg%s]", pr.transErrMm, pr.rotErrDeg, pr.success ? "" : " WRONG");
          else std::printf(" FALSE]");
        } else {
          std::printf("  [miss t%d vis %d/%d]", pr.truth, s->parts[static_cast<std::size_t>(pr.truth)].visiblePixels,
                      s->parts[static_cast<std::size_t>(pr.truth)].pixels);
        }
      }
      if (r->parts.empty()) std::printf("  (%s; best %.2f)", r->reason.c_str(), r->bestOtherFitness);
      std::printf("\n");
      std::fflush(stdout);
    }
  }
  const auto sum = acc.summary();
  std::printf(
      "{\"part\":\"%s\",\"preset\":\"%s\",\"scenes\":%d,\"parts\":%d,\"empty_images\":%d,\"success_rate\":%.4f,\"trans_err_mm_mean\":%.3f,"
      "\"trans_err_mm_max\":%.3f,\"rot_err_deg_mean\":%.3f,\"rot_err_deg_max\":%.3f,\"add_mm_mean\":%.3f,\"missed\":%d,"
      "\"false_positives\":%d,\"retries\":%d,\"not_found\":%d,\"time_ms_median\":%.1f,\"cpu_ms_median\":%.1f,\"time_ms_max\":%.1f}\n",
      scene.part.c_str(), preset.c_str(), sum.images, sum.parts, sum.emptyImages, sum.successRate(), sum.transErrMean, sum.transErrMax,
      sum.rotErrMean, sum.rotErrMax, sum.addMean, sum.missed, sum.falsePositives, sum.retries, sum.notFound, sum.timeMsMedian,
      sum.cpuMsMedian, sum.timeMsMax);
  return 0;
}
