// vgr-bench-features: every localization method on the same synthetic images (a textured
// part, flat or with raised layers seen off-centre, rotated within +-angle, Gaussian noise),
// with paper 000's success criterion (<= pos-tol px and <= ang-tol deg at the grasp point)
// and paper 001's match true-positive rate (accepted matches within 3 px of the truth on
// the belt plane). Until `vgr sim render` + `vgr eval` measure on the scene renderer, these
// are the numbers in docs/localization-methods.md.
#include <algorithm>
#include <chrono>
#include <cstdio>
#include <random>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>

#include "core/cli.hpp"
#include <fmt/core.h>
#include <opencv2/core.hpp>

#include "sim/synth_part.hpp"
#include "vision/locate/locator.hpp"

int main(int argc, char** argv) {
  CLI::App app{"Localization methods on synthetic textured parts"};
  vgr::cli::showDefaults(app);
  int count = 100;
  unsigned seed = 1;
  double angle = 60, noise = 5, posTol = 4, angTol = 0.5;
  bool multi = false;
  double heightFactor = 0.05;
  bool autoRegions = false;
  std::vector<std::string> methods;
  app.add_option("--count", count, "images");
  app.add_option("--seed", seed, "random seed");
  app.add_option("--angle", angle, "poses within +-angle degrees");
  app.add_option("--noise", noise, "Gaussian noise sigma, gray levels");
  app.add_flag("--multi-height", multi, "raised layers (boss 30 mm, rib 45 mm; camera 600 mm)");
  app.add_option("--height-factor", heightFactor, "contour-weighted: epsilon of the raised regions (eq. 3)");
  app.add_flag("--auto-regions", autoRegions, "contour-weighted: split regions automatically (epsilon = 1)");
  app.add_option("--pos-tol", posTol, "success: position error <= px");
  app.add_option("--ang-tol", angTol, "success: angle error <= deg");
  app.add_option("--method", methods, "methods (default: all but moments)");
  if (const auto rc = vgr::cli::parse(app, argc, argv)) return *rc;
  if (methods.empty())
    for (const auto& m : vgr::vision::locatorMethods())
      if (m != "moments") methods.push_back(m);

  const auto part = vgr::sim::synth::makeTexturedPart(multi);
  const auto templ = vgr::sim::synth::makeTemplate(part, 30, heightFactor);
  const cv::Size size(1280, 1024);
  for (const auto& method : methods) {
    vgr::vision::TaughtTemplate taught;
    taught.grasp = templ.grasp;
    taught.minScore = 0.3;
    if (multi && !autoRegions && method == "contour-weighted") taught.regions = templ.regions;
    auto loc = vgr::vision::makeLocator(method, templ.image, taught);
    if (!loc) {
      std::printf("%s: %s\n", method.c_str(), loc.error().message.c_str());
      continue;
    }
    std::mt19937 rng(seed);
    int ok = 0, found = 0;
    double posSum = 0, posMax = 0, angSum = 0, angMax = 0, tpSum = 0;
    int tpN = 0;
    std::vector<double> times;
    for (int k = 0; k < count; ++k) {
      const auto pose = vgr::sim::synth::randomPose(rng, size, angle);
      const cv::Mat img = vgr::sim::synth::renderScene(part, {pose}, size, noise, seed * 100000u + static_cast<unsigned>(k));
      const auto t0 = std::chrono::steady_clock::now();
      auto out = (*loc)->locate(img);
      times.push_back(std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count());
      if (!out || out->parts.empty()) continue;
      ++found;
      const auto& d = out->parts.front();
      const double pe = std::hypot(d.u - pose.u, d.v - pose.v), ae = vgr::sim::synth::angleDiffDeg(d.angleDeg, pose.angleDeg);
      posSum += pe;
      angSum += ae;
      posMax = std::max(posMax, pe);
      angMax = std::max(angMax, ae);
      if (pe <= posTol && ae <= angTol) ++ok;
      if (!out->matches.empty()) {
        tpSum += vgr::sim::synth::matchTruePositiveRate(out->matches, pose, templ.grasp);
        ++tpN;
      }
    }
    std::sort(times.begin(), times.end());
    std::printf("%s\n", fmt::format("{{\"method\":\"{}\",\"n\":{},\"found\":{},\"success_rate\":{:.3f},\"pos_err_px_mean\":{:.3f},"
                                    "\"pos_err_px_max\":{:.3f},\"ang_err_deg_mean\":{:.3f},\"ang_err_deg_max\":{:.3f},"
                                    "\"match_tp_rate\":{:.4f},\"time_ms_median\":{:.1f}}}",
                                    method, count, found, static_cast<double>(ok) / count, found ? posSum / found : 0.0, posMax,
                                    found ? angSum / found : 0.0, angMax, tpN ? tpSum / tpN : 0.0, times[times.size() / 2])
                            .c_str());
    std::fflush(stdout);
  }
  return 0;
}
