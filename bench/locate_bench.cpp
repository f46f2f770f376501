// vgr-bench-locate: every localization method (vision::locatorMethods()) on the same rendered
// images, printing median time, success and mean/max errors as a table (docs/performance.md).
//   images: 2448x2048, sim part ~300 px long (camera 800 mm above the plane, f = 2400 px),
//   Gaussian noise sigma 5, part centroid uniform in the image (200 px margin), rotation
//   uniform in the search range; the template is the part at 0 deg cut from its own noisy
//   rendering, the grasp point its centroid.
//   success: the best detection within 2 px and 1 deg of the truth; errors are over successes.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <numbers>
#include <random>
#include <cstdlib>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"
#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "core/angles.hpp"
#include "sim/locate_scenes.hpp"
#include "vision/locate/locator.hpp"

namespace {

using Clock = std::chrono::steady_clock;

struct Row {
  std::string method;
  std::vector<double> ms;
  int ok = 0, n = 0;
  double sumPos = 0, maxPos = 0, sumAng = 0, maxAng = 0;
};

double median(std::vector<double> v) {
  if (v.empty()) return 0;
  std::sort(v.begin(), v.end());
  return v[v.size() / 2];
}

}  // namespace

int main(int argc, char** argv) {
  CLI::App app{"vgr-bench-locate: localization methods on the same rendered images"};
  vgr::cli::showDefaults(app);
  int width = 2448, height = 2048, images = 100;
  double sigma = 5, range = 180, focal = 2400, camHeight = 800, templateAngle = 0;
  std::uint64_t seed = 1;
  std::vector<std::string> methods;
  std::vector<std::string> params;
  app.add_option("--width", width)->check(CLI::Range(256, 8192));
  app.add_option("--height", height)->check(CLI::Range(256, 8192));
  app.add_option("--images", images)->check(CLI::Range(1, 100000));
  app.add_option("--sigma", sigma, "noise, gray levels")->check(CLI::Range(0.0, 50.0));
  app.add_option("--range", range, "rotation range +-deg (180 = full circle)")->check(CLI::Range(0.0, 180.0));
  app.add_option("--focal", focal, "focal length, px (part length ~ 100 * focal / height px)");
  app.add_option("--camera-height", camHeight, "mm above the plane");
  app.add_option("--seed", seed);
  bool verbose = false, drawnTruth = false;
  app.add_flag("--drawn-truth", drawnTruth,
               "positions against the centroid the renderer actually drew (template grasp point too), "
               "not SceneTruth's (see drawnCentroid)");
  app.add_flag("--verbose", verbose, "print every image's signed error in the part frame");
  app.add_option("--template-angle", templateAngle, "deg, the part in the template image (CCW as displayed)");
  app.add_option("--methods", methods, "methods to run (default: all of locatorMethods())");
  app.add_option("--param", params, "method parameter NAME=VALUE (every method gets it)");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  if (methods.empty()) methods = vgr::vision::locatorMethods();

  const auto renderer = vgr::sim::makeRenderer(width, height, focal, camHeight, sigma, seed);
  const auto tp = vgr::sim::makeSceneTemplate(renderer, templateAngle, 20, seed * 7919 + 3);
  vgr::vision::TaughtTemplate taught;
  taught.grasp = drawnTruth ? tp.graspDrawn : tp.grasp;
  taught.angleMinDeg = -range;
  taught.angleMaxDeg = range;
  for (const auto& kv : params) {
    const auto eq = kv.find('=');
    if (eq == std::string::npos) {
      std::fprintf(stderr, "--param %s: expected NAME=VALUE\n", kv.c_str());
      return 2;
    }
    taught.params[kv.substr(0, eq)] = kv.substr(eq + 1);
  }

  // Render all images first (the renderer is not what is measured).
  std::mt19937_64 rng(seed * 1000003 + 17);
  std::uniform_real_distribution<double> du(200, width - 201), dv(200, height - 201), da(-range, range);
  std::vector<cv::Mat> imgs(static_cast<std::size_t>(images));
  std::vector<vgr::sim::SceneTruth> truths;
  for (int i = 0; i < images; ++i) {
    const double angle = range >= 180 ? da(rng) : da(rng);
    truths.push_back(vgr::sim::truthAt(renderer, du(rng), dv(rng), tp.truth.angleImgDeg + angle));
    renderer.renderTruth(truths.back(), seed * 7777 + static_cast<std::uint64_t>(i), imgs[i]);
    if (drawnTruth) {
      const auto c = vgr::sim::drawnCentroid(renderer, truths.back());
      truths.back().uPx = c.u, truths.back().vPx = c.v;
    }
  }

  std::vector<Row> rows;
  for (const auto& method : methods) {
    Row row;
    row.method = method;
    auto made = vgr::vision::makeLocator(method, tp.image, taught);
    if (!made) {
      std::fprintf(stderr, "%s: %s\n", method.c_str(), made.error().message.c_str());
      continue;
    }
    auto& loc = **made;
    (void)loc.locate(imgs[0]);  // warm-up: buffers for this image size
    for (int i = 0; i < images; ++i) {
      const auto t0 = Clock::now();
      auto out = loc.locate(imgs[i]);
      row.ms.push_back(std::chrono::duration<double, std::milli>(Clock::now() - t0).count());
      ++row.n;
      if (!out || out->parts.empty()) continue;
      const auto& d = out->parts.front();
      const auto& t = truths[i];
      const double pos = std::hypot(d.u - t.uPx, d.v - t.vPx);
      const double ang = std::abs(vgr::normaliseDeg(d.angleDeg - (t.angleImgDeg - tp.truth.angleImgDeg)));
      if (verbose) {
        // Signed error in the part's frame (x along the part's axis as displayed).
        const double a = t.angleImgDeg * std::numbers::pi / 180, ex = d.u - t.uPx, ey = d.v - t.vPx;
        std::printf("%s %d err_part %+.4f %+.4f ang %+.4f\n", method.c_str(), i, ex * std::cos(a) - ey * std::sin(a),
                    ex * std::sin(a) + ey * std::cos(a), d.angleDeg - (t.angleImgDeg - tp.truth.angleImgDeg));
      }
      if (pos > 2 || ang > 1) continue;
      ++row.ok;
      row.sumPos += pos, row.maxPos = std::max(row.maxPos, pos);
      row.sumAng += ang, row.maxAng = std::max(row.maxAng, ang);
    }
    rows.push_back(row);
  }

  std::printf("%dx%d, %d images, sigma %.1f, rotation +-%.0f deg, part ~%.0f px long, truth: %s\n", width, height, images,
              sigma, range, 100 * focal / camHeight, drawnTruth ? "drawn centroid" : "SceneTruth");
  std::printf("| method | median ms | success | mean px | max px | mean deg | max deg |\n");
  std::printf("|---|---:|---:|---:|---:|---:|---:|\n");
  for (const Row& r : rows) {
    const double k = r.ok > 0 ? r.ok : 1;
    std::printf("| %s | %.1f | %d/%d | %.4f | %.4f | %.4f | %.4f |\n", r.method.c_str(), median(r.ms), r.ok, r.n,
                r.sumPos / k, r.maxPos, r.sumAng / k, r.maxAng);
  }
  return 0;
}
