#include "tools/vgr/teach.hpp"

#include <cstdio>
#include <exception>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job.hpp"
#include "vision/gray_image.hpp"
#include "vision/locate/locator.hpp"
#include "vision/locate/regions.hpp"

namespace vgr::tools {
namespace {

bool parseNumbers(const std::string& text, std::size_t n, std::vector<double>& out) {
  out.clear();
  std::string cur;
  for (char c : text + ",") {
    if (c != ',') {
      cur += c;
      continue;
    }
    try {
      std::size_t used = 0;
      out.push_back(std::stod(cur, &used));
      if (used != cur.size()) return false;
    } catch (const std::exception&) {
      return false;
    }
    cur.clear();
  }
  return out.size() == n;
}

}  // namespace

int runTeach(const TeachOptions& o) {
  namespace fs = std::filesystem;
  const cv::Mat img = vision::readGray8(o.image).value_or(cv::Mat());
  if (img.empty()) return badInput(o.image + ": cannot read the image");
  config::JobFile job;
  job.folder = o.out;
  job.name = o.name.empty() ? fs::path(o.out).filename().string() : o.name;
  job.method = o.method;
  for (const auto& g : o.grasps) {
    std::vector<double> v;
    if (!parseNumbers(g, 2, v)) return badInput(fmt::format("--grasp: expected X,Y in template px, got '{}'", g));
    if (v[0] < 0 || v[1] < 0 || v[0] > img.cols - 1 || v[1] > img.rows - 1)
      return badInput(fmt::format("--grasp {}: outside the {}x{} image", g, img.cols, img.rows));
    job.grasps.push_back({v[0], v[1]});
  }
  job.taught.grasp = job.grasps.front();
  if (!o.roi.empty()) {
    std::vector<double> v;
    if (!parseNumbers(o.roi, 4, v) || v[0] < 0 || v[1] < 0 || v[2] <= 0 || v[3] <= 0)
      return badInput(fmt::format("--roi: expected X,Y,W,H (px, W and H > 0), got '{}'", o.roi));
    job.taught.searchRoi = {static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]), static_cast<int>(v[3])};
  }
  job.taught.minScore = o.minScore;
  job.taught.maxParts = o.maxParts;
  job.taught.angleMinDeg = o.angleMin;
  job.taught.angleMaxDeg = o.angleMax;
  if (o.angleMax < o.angleMin) return badInput("--angle-max must not be below --angle-min");
  job.partHeightMm = o.partHeightMm;
  for (const auto& p : o.params) {
    const auto eq = p.find('=');
    if (eq == std::string::npos || eq == 0) return badInput(fmt::format("--param: expected NAME=VALUE, got '{}'", p));
    job.taught.params[p.substr(0, eq)] = p.substr(eq + 1);
  }
  if (!o.polarity.empty()) {
    if (job.method != "moments" && job.method != "hu" && job.method != "shape")
      return badInput(fmt::format("--polarity: method {} has no polarity (moments, hu and shape have)", job.method));
    if (job.taught.params.contains("polarity")) return badInput("--polarity and --param polarity=...: give it once");
    job.taught.params["polarity"] = o.polarity;
  }
  if (!o.regionsFile.empty()) {
    auto regs = config::loadRegions(o.regionsFile);
    if (!regs) return badInput(regs.error().message);
    job.taught.regions = *regs;
  } else if (o.autoRegions) {
    job.taught.regions = vision::splitTemplateRegions(img);
  }
  // The method must accept the template and the parameters before anything is written.
  auto locator = vision::makeLocator(job.method, img, job.taught);
  if (!locator) return badInput(locator.error().message);
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) return badInput(fmt::format("{}: cannot create the job folder: {}", o.out, ec.message()));
  if (!cv::imwrite(job.templatePath(), img)) return badInput(job.templatePath() + ": cannot write");
  if (auto w = config::writeJob(job); !w) return badInput(w.error().message);
  // Read back: what was written must load.
  auto back = config::loadJob(o.out);
  if (!back) return badInput("written job does not load: " + back.error().message);
  std::printf("%s: job '%s', method %s, %zu region(s)\n", o.out.c_str(), job.name.c_str(), job.method.c_str(),
              job.taught.regions.size());
  return 0;
}

CLI::App* TeachCommand::add(CLI::App& parent) {
  auto& t = options_;
  auto* teachCmd = parent.add_subcommand("teach", "create a job folder from a template image (docs/localization.md)");
  teachCmd->add_option("--image", t.image, "template image (the part as taught)")->required();
  teachCmd->add_option("--grasp", t.grasps, "grasp point X,Y in template px (repeat for more; the first is located)")->required();
  teachCmd->add_option("--roi", t.roi, "search region X,Y,W,H in live images (default: whole image)");
  teachCmd->add_option("--method", t.method, "locate method");
  teachCmd->add_option("--param", t.params, "method parameter NAME=VALUE (repeatable)");
  teachCmd->add_option("--polarity", t.polarity,
                       "moments, hu, shape: use (the template's dark/bright sense, default), ignore_global (a part may "
                       "be inverted), ignore_local (shape only: each edge may be)")
      ->check(CLI::IsMember({"use", "ignore_global", "ignore_local"}));
  teachCmd->add_option("--regions", t.regionsFile, "YAML file with a 'regions' list (e.g. a dataset's template.yaml)");
  teachCmd->add_flag("!--no-auto-regions", t.autoRegions, "do not split regions from the template's contours");
  teachCmd->add_option("--min-score", t.minScore, "[0, 1]")->check(CLI::Range(0.0, 1.0));
  teachCmd->add_option("--max-parts", t.maxParts, "[1, 64]")->check(CLI::Range(1, 64));
  teachCmd->add_option("--angle-min", t.angleMin, "deg")->check(CLI::Range(-180.0, 180.0));
  teachCmd->add_option("--angle-max", t.angleMax, "deg")->check(CLI::Range(-180.0, 180.0));
  teachCmd->add_option("--part-height", t.partHeightMm, "grasp height above the conveyor, mm")->check(CLI::Range(0.0, 1000.0));
  teachCmd->add_option("--name", t.name, "job name (default: the folder name)");
  teachCmd->add_option("--out", t.out, "job folder to create")->required();
  return teachCmd;
}

}  // namespace vgr::tools
