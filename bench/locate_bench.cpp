// vgr-bench-locate: every localization method (vision::locatorMethods()) on the same rendered
// images, printing median time (wall and process CPU), success and mean/max errors as a table
// (docs/performance.md).
//   --scene sim (default): 2448x2048, the sim part ~300 px long (camera 800 mm above the
//     plane, f = 2400 px), Gaussian noise sigma 5, part centroid uniform in the image (200 px
//     margin), rotation uniform in the search range; the template is the part at 0 deg cut
//     from its own noisy rendering, the grasp point its centroid.
//   --scene gear | plate: the real-parts set of sim/shape_scenes.hpp: a 24-tooth gear or a
//     slotted plate of --size px (default 450), 2448x2048, --clutter shapes (default 8), a
//     --illum lighting gradient (default 2:1), noise sigma 5, rotation uniform in the range,
//     scale uniform in [--part-scale-min, --part-scale-max] (default: the job's range),
//     optional --perspective; the template is the part at scale 1 and 0 deg, noise sigma 5.
//   success: the best detection within 2 px and 1 deg (and 1 % in scale) of the truth; errors
//   are over successes.
//   --profile: the shape matcher's per-stage medians (vision::shapeStageTimes).
// Times: Locator::locate() only, after one warm-up call; wall (steady clock) and CPU of the
// whole process (CLOCK_PROCESS_CPUTIME_ID: every thread of the search). Pin with taskset and
// report `uptime`: the machine is shared.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <cstdlib>
#include <ctime>
#include <numbers>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"
#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "core/angles.hpp"
#include "sim/locate_scenes.hpp"
#include "sim/shape_scenes.hpp"
#include "vision/locate/locator.hpp"
#include "vision/locate/shape_matcher.hpp"

namespace {

using Clock = std::chrono::steady_clock;

struct Row {
  std::string method;
  std::vector<double> ms, cpuMs;
  std::vector<double> stageWall[vgr::vision::ShapeStageTimes::kCount], stageCpu[vgr::vision::ShapeStageTimes::kCount];
  int ok = 0, n = 0;
  double sumPos = 0, maxPos = 0, sumAng = 0, maxAng = 0, sumScale = 0, maxScale = 0;
};

struct Truth {
  double u = 0, v = 0, angleDeg = 0, scale = 1;  // grasp point, rotation from the template, scale
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

double cpuNowMs() {
  timespec t{};
  clock_gettime(CLOCK_PROCESS_CPUTIME_ID, &t);
  return t.tv_sec * 1e3 + t.tv_nsec * 1e-6;
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-bench-locate: localization methods on the same rendered images"};
  vgr::cli::showDefaults(app);
  int width = 2448, height = 2048, images = 100, clutter = 8, repeat = 1;
  double sigma = 5, range = 180, focal = 2400, camHeight = 800, templateAngle = 0, size = 450, illum = 2;
  double scaleMin = 1, scaleMax = 1, partScaleMin = 0, partScaleMax = 0, perspective = 0;
  std::uint64_t seed = 1;
  std::string scene = "sim";
  std::vector<std::string> methods;
  std::vector<std::string> params;
  app.add_option("--scene", scene, "sim (the sim part), gear or plate (sim/shape_scenes.hpp)")
      ->check(CLI::IsMember({"sim", "gear", "plate"}));
  app.add_option("--width", width)->check(CLI::Range(256, 8192));
  app.add_option("--height", height)->check(CLI::Range(256, 8192));
  app.add_option("--images", images)->check(CLI::Range(1, 100000));
  app.add_option("--sigma", sigma, "noise, gray levels")->check(CLI::Range(0.0, 50.0));
  app.add_option("--range", range, "rotation range +-deg (180 = full circle)")->check(CLI::Range(0.0, 180.0));
  app.add_option("--focal", focal, "sim: focal length, px (part length ~ 100 * focal / height px)");
  app.add_option("--camera-height", camHeight, "sim: mm above the plane");
  app.add_option("--size", size, "gear/plate: part size in the template, px (gear diameter, plate length)")
      ->check(CLI::Range(40.0, 2000.0));
  app.add_option("--clutter", clutter, "gear/plate: clutter shapes per image")->check(CLI::Range(0, 64));
  app.add_option("--illum", illum, "gear/plate: lighting gradient, brightest : darkest corner")->check(CLI::Range(1.0, 10.0));
  app.add_option("--scale-min", scaleMin, "the job's scale range (image px per template px)")->check(CLI::Range(0.2, 5.0));
  app.add_option("--scale-max", scaleMax, "the job's scale range")->check(CLI::Range(0.2, 5.0));
  app.add_option("--part-scale-min", partScaleMin, "gear/plate: parts rendered at scales from (default: --scale-min)");
  app.add_option("--part-scale-max", partScaleMax, "gear/plate: ... to (default: --scale-max)");
  app.add_option("--perspective", perspective, "gear/plate: projective term |g|, 1/px (0 = none)")->check(CLI::Range(0.0, 1e-3));
  app.add_option("--seed", seed);
  app.add_option("--repeat", repeat, "locate each image this many times (profilers: perf, callgrind); times are of the last")
      ->check(CLI::Range(1, 1000));
  bool verbose = false, drawnTruth = false, profile = false;
  app.add_flag("--drawn-truth", drawnTruth,
               "sim: positions against the centroid the renderer actually drew (template grasp point too), "
               "not SceneTruth's (see drawnCentroid)");
  app.add_flag("--verbose", verbose, "print every image's signed error in the part frame");
  app.add_flag("--profile", profile, "per-stage medians of the shape matcher");
  app.add_option("--template-angle", templateAngle, "sim: deg, the part in the template image (CCW as displayed)");
  app.add_option("--methods", methods, "methods to run (default: all of locatorMethods())");
  app.add_option("--param", params, "method parameter NAME=VALUE (every method gets it)");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  if (methods.empty()) methods = vgr::vision::locatorMethods();
  if (scaleMax < scaleMin) {
    std::fprintf(stderr, "--scale-max must not be below --scale-min\n");
    return 2;
  }
  if (partScaleMin <= 0) partScaleMin = scaleMin;
  if (partScaleMax <= 0) partScaleMax = scaleMax;

  vgr::vision::TaughtTemplate taught;
  taught.angleMinDeg = -range;
  taught.angleMaxDeg = range;
  taught.scaleMin = scaleMin;
  taught.scaleMax = scaleMax;
  for (const auto& kv : params) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) {
      std::fprintf(stderr, "--param %s: expected NAME=VALUE\n", kv.c_str());
      return 2;
    }
    taught.params[kv.substr(0, eq)] = kv.substr(eq + 1);
  }

  // Render all images first (the renderer is not what is measured).
  std::vector<cv::Mat> imgs(static_cast<std::size_t>(images));
  std::vector<Truth> truths;
  cv::Mat templ;
  std::string what;
  if (scene == "sim") {
    const auto renderer = vgr::sim::makeRenderer(width, height, focal, camHeight, sigma, seed);
    const auto tp = vgr::sim::makeSceneTemplate(renderer, templateAngle, 20, seed * 7919 + 3);
    templ = tp.image;
    taught.grasp = drawnTruth ? tp.graspDrawn : tp.grasp;
    std::mt19937_64 rng(seed * 1000003 + 17);
    std::uniform_real_distribution<double> du(200, width - 201), dv(200, height - 201), da(-range, range);
    for (int i = 0; i < images; ++i) {
      const double angle = da(rng);
      auto t = vgr::sim::truthAt(renderer, du(rng), dv(rng), tp.truth.angleImgDeg + angle);
      renderer.renderTruth(t, seed * 7777 + static_cast<std::uint64_t>(i), imgs[i]);
      if (drawnTruth) {
        const auto c = vgr::sim::drawnCentroid(renderer, t);
        t.uPx = c.u, t.vPx = c.v;
      }
      truths.push_back({t.uPx, t.vPx, vgr::normaliseDeg(t.angleImgDeg - tp.truth.angleImgDeg), 1});
    }
    what = fmt::format("sim part ~{:.0f} px long, truth: {}", 100 * focal / camHeight, drawnTruth ? "drawn centroid" : "SceneTruth");
  } else {
    auto part = vgr::sim::shapes::partByName(scene, size);
    if (!part) {
      std::fprintf(stderr, "%s\n", part.error().message.c_str());
      return 2;
    }
    const auto tp = vgr::sim::shapes::renderTemplate(*part, 20, sigma, seed * 7919 + 3);
    templ = tp.image;
    taught.grasp = {tp.graspU, tp.graspV};
    const auto poses = vgr::sim::shapes::randomPoses(*part, {width, height}, images, range, partScaleMin, partScaleMax,
                                                     perspective, 8, seed);
    vgr::sim::shapes::ShapeSceneOptions o;
    o.size = {width, height};
    o.noiseSigma = sigma;
    o.illumRatio = illum;
    o.clutter = clutter;
    for (int i = 0; i < images; ++i) {
      o.seed = seed * 7777 + static_cast<std::uint64_t>(i);
      vgr::sim::shapes::renderScene(*part, {poses[i]}, o, imgs[i]);
      truths.push_back({poses[i].u, poses[i].v, vgr::normaliseDeg(poses[i].angleDeg), poses[i].scale});
    }
    what = fmt::format("{} {:.0f} px (template {}x{}), {} clutter, lighting {:.1f}:1, part scale [{}, {}], perspective {}",
                       scene, size, templ.cols, templ.rows, clutter, illum, partScaleMin, partScaleMax, perspective);
  }

  std::vector<Row> rows;
  for (const auto& method : methods) {
    Row row;
    row.method = method;
    // --profile: the shape locator itself (makeLocator wraps it in the input checks, which
    // hide its stage times).
    auto made = profile && method == "shape" ? vgr::vision::makeShapeLocator(templ, taught)
                                             : vgr::vision::makeLocator(method, templ, taught);
    if (!made) {
      std::fprintf(stderr, "%s: %s\n", method.c_str(), made.error().message.c_str());
      continue;
    }
    auto& loc = **made;
    (void)loc.locate(imgs[0]);  // warm-up: buffers for this image size
    for (int i = 0; i < images; ++i) {
      for (int k = 1; k < repeat; ++k) (void)loc.locate(imgs[i]);
      const double c0 = cpuNowMs();
      const auto t0 = Clock::now();
      auto out = loc.locate(imgs[i]);
      row.ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      row.cpuMs.push_back(cpuNowMs() - c0);
      if (const auto* st = vgr::vision::shapeStageTimes(loc); st && profile)
        for (int s = 0; s < vgr::vision::ShapeStageTimes::kCount; ++s) {
          row.stageWall[s].push_back(st->wallMs[s]);
          row.stageCpu[s].push_back(st->cpuMs[s]);
        }
      ++row.n;
      if (!out || out->parts.empty()) {
        if (verbose) std::printf("%s %d not found\n", method.c_str(), i);
        continue;
      }
      const auto& d = out->parts.front();
      const auto& t = truths[i];
      const double pos = std::hypot(d.u - t.u, d.v - t.v);
      const double ang = std::abs(vgr::normaliseDeg(d.angleDeg - t.angleDeg));
      const double scl = std::abs(d.scale / t.scale - 1) * 100;
      if (verbose) {
        // Signed error in the part's frame (x along the part's axis as displayed).
        const double a = t.angleDeg * std::numbers::pi / 180, ex = d.u - t.u, ey = d.v - t.v;
        std::printf("%s %d err_part %+.4f %+.4f ang %+.4f scale %+.4f %% score %.3f\n", method.c_str(), i,
                    ex * std::cos(a) - ey * std::sin(a), ex * std::sin(a) + ey * std::cos(a),
                    vgr::normaliseDeg(d.angleDeg - t.angleDeg), (d.scale / t.scale - 1) * 100, d.score);
      }
      if (pos > 2 || ang > 1 || scl > 1) continue;
      ++row.ok;
      row.sumPos += pos, row.maxPos = std::max(row.maxPos, pos);
      row.sumAng += ang, row.maxAng = std::max(row.maxAng, ang);
      row.sumScale += scl, row.maxScale = std::max(row.maxScale, scl);
    }
    rows.push_back(std::move(row));
  }

  std::printf("%dx%d, %d images, sigma %.1f, rotation +-%.0f deg, job scale [%g, %g], %s\n", width, height, images, sigma, range,
              scaleMin, scaleMax, what.c_str());
  std::printf("| method | median ms | median CPU ms | success | mean px | max px | mean deg | max deg | mean scale %% | max scale %% |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& r : rows) {
    const double k = r.ok > 0 ? r.ok : 1;
    std::printf("| %s | %.1f | %.1f | %d/%d | %.4f | %.4f | %.4f | %.4f | %.4f | %.4f |\n", r.method.c_str(), median(r.ms),
                median(r.cpuMs), r.ok, r.n, r.sumPos / k, r.maxPos, r.sumAng / k, r.maxAng, r.sumScale / k, r.maxScale);
  }
  if (profile)
    for (const Row& r : rows) {
      if (r.stageWall[0].empty()) continue;
      std::printf("\n%s per stage (median ms): | stage | wall | CPU |\n|---|---:|---:|\n", r.method.c_str());
      for (int s = 0; s < vgr::vision::ShapeStageTimes::kCount; ++s)
        std::printf("| %s | %.2f | %.2f |\n", vgr::vision::ShapeStageTimes::name(s), median(r.stageWall[s]),
                    median(r.stageCpu[s]));
    }
  return 0;
}
