#include "daemon/locate_cli.hpp"

#include <chrono>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <map>
#include <string>
#include <vector>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/cell_config.hpp"
#include "config/job.hpp"
#include "core/pose.hpp"
#include "daemon/locate_eval.hpp"
#include "sim/dataset.hpp"
#include "vision/calib/plane_model.hpp"
#include "vision/locate/locator.hpp"
#include "vision/locate/regions.hpp"

namespace vgr::daemon {
namespace {

constexpr double kDegToRad = M_PI / 180.0;

struct TeachOptions {
  std::string image, out, method = "moments", roi, regionsFile, name;
  std::vector<std::string> grasps, params;
  double minScore = 0.5, angleMin = -180, angleMax = 180, partHeightMm = 0;
  int maxParts = 1;
  bool autoRegions = true;
};

struct LocateOptions {
  std::string job, image, method;
  bool json = false;
};

int errorOut(const std::string& msg) {
  std::fprintf(stderr, "%s\n", msg.c_str());
  return 2;
}

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

int runSimRender(const sim::DatasetOptions& o) {
  auto r = sim::writeDataset(o);
  if (!r) return errorOut(r.error().message);
  std::printf("{\"out\":\"%s\",\"images\":%d,\"empty_images\":%d,\"parts\":%d}\n", o.outDir.c_str(), r->images, r->emptyImages,
              r->parts);
  return 0;
}

int runTeach(const TeachOptions& o) {
  namespace fs = std::filesystem;
  const cv::Mat img = cv::imread(o.image, cv::IMREAD_GRAYSCALE);
  if (img.empty()) return errorOut(o.image + ": cannot read the image");
  config::JobFile job;
  job.folder = o.out;
  job.name = o.name.empty() ? fs::path(o.out).filename().string() : o.name;
  job.method = o.method;
  for (const auto& g : o.grasps) {
    std::vector<double> v;
    if (!parseNumbers(g, 2, v)) return errorOut(fmt::format("--grasp: expected X,Y in template px, got '{}'", g));
    if (v[0] < 0 || v[1] < 0 || v[0] > img.cols - 1 || v[1] > img.rows - 1)
      return errorOut(fmt::format("--grasp {}: outside the {}x{} image", g, img.cols, img.rows));
    job.grasps.push_back({v[0], v[1]});
  }
  job.taught.grasp = job.grasps.front();
  if (!o.roi.empty()) {
    std::vector<double> v;
    if (!parseNumbers(o.roi, 4, v) || v[0] < 0 || v[1] < 0 || v[2] <= 0 || v[3] <= 0)
      return errorOut(fmt::format("--roi: expected X,Y,W,H (px, W and H > 0), got '{}'", o.roi));
    job.taught.searchRoi = {static_cast<int>(v[0]), static_cast<int>(v[1]), static_cast<int>(v[2]), static_cast<int>(v[3])};
  }
  job.taught.minScore = o.minScore;
  job.taught.maxParts = o.maxParts;
  job.taught.angleMinDeg = o.angleMin;
  job.taught.angleMaxDeg = o.angleMax;
  if (o.angleMax < o.angleMin) return errorOut("--angle-max must not be below --angle-min");
  job.partHeightMm = o.partHeightMm;
  for (const auto& p : o.params) {
    const auto eq = p.find('=');
    if (eq == std::string::npos || eq == 0) return errorOut(fmt::format("--param: expected NAME=VALUE, got '{}'", p));
    job.taught.params[p.substr(0, eq)] = p.substr(eq + 1);
  }
  if (!o.regionsFile.empty()) {
    auto regs = config::loadRegions(o.regionsFile);
    if (!regs) return errorOut(regs.error().message);
    job.taught.regions = *regs;
  } else if (o.autoRegions) {
    job.taught.regions = vision::splitTemplateRegions(img);
  }
  // The method must accept the template and the parameters before anything is written.
  auto locator = vision::makeLocator(job.method, img, job.taught);
  if (!locator) return errorOut(locator.error().message);
  std::error_code ec;
  fs::create_directories(o.out, ec);
  if (ec) return errorOut(fmt::format("{}: cannot create the job folder: {}", o.out, ec.message()));
  if (!cv::imwrite(job.templatePath(), img)) return errorOut(job.templatePath() + ": cannot write");
  if (auto w = config::writeJob(job); !w) return errorOut(w.error().message);
  // Read back: what was written must load.
  auto back = config::loadJob(o.out);
  if (!back) return errorOut("written job does not load: " + back.error().message);
  std::printf("%s: job '%s', method %s, %zu region(s)\n", o.out.c_str(), job.name.c_str(), job.method.c_str(),
              job.taught.regions.size());
  return 0;
}

// Pixels -> robot base frame with the job's calibration (a cell config's `model`), at the
// part's grasp height; the angle is the direction of a 20 px step along the part's axis,
// mapped the same way (as daemon/cycle_runner.cpp does).
struct RobotMapping {
  vision::PinholePlaneModel model;
  double heightMm;
};

int runLocate(const LocateOptions& o) {
  auto job = config::loadJob(o.job);
  if (!job) return errorOut(job.error().message);
  const std::string method = o.method.empty() ? job->method : o.method;
  const cv::Mat templ = cv::imread(job->templatePath(), cv::IMREAD_GRAYSCALE);
  if (templ.empty()) return errorOut(job->templatePath() + ": cannot read the template image");
  const cv::Mat img = cv::imread(o.image, cv::IMREAD_GRAYSCALE);
  if (img.empty()) return errorOut(o.image + ": cannot read the image");
  std::optional<RobotMapping> robot;
  if (!job->calibration.empty()) {
    auto cell = config::loadCellConfig(job->calibrationPath());
    if (!cell) return errorOut(cell.error().message);
    const auto& m = cell->model;
    robot = RobotMapping{vision::PinholePlaneModel(m.fx, m.fy, m.cx, m.cy,
                                                   vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg),
                                                   m.planeZ),
                         job->partHeightMm};
  }
  auto locator = vision::makeLocator(method, templ, job->taught);
  if (!locator) return errorOut(locator.error().message);
  const auto t0 = std::chrono::steady_clock::now();
  auto out = (*locator)->locate(img);
  const double ms = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - t0).count();
  nlohmann::ordered_json j;
  if (!out) {
    j["status"] = static_cast<int>(out.error().code);
    j["error"] = out.error().message;
    j["time_ms"] = ms;
    j["parts"] = nlohmann::json::array();
    std::printf("%s\n", j.dump().c_str());
    return 1;
  }
  j["status"] = out->parts.empty() ? static_cast<int>(Status::NoPartFound) : static_cast<int>(Status::Ok);
  j["method"] = method;
  j["time_ms"] = ms;
  j["parts"] = nlohmann::json::array();
  for (const auto& d : out->parts) {
    nlohmann::ordered_json p;
    p["x_px"] = d.u;
    p["y_px"] = d.v;
    p["angle_deg"] = d.angleDeg;
    p["score"] = d.score;
    if (robot) {
      const double a = d.angleDeg * kDegToRad;
      const auto q0 = robot->model.pixelToPlane({d.u, d.v}, robot->heightMm);
      const auto q1 = robot->model.pixelToPlane({d.u + 20 * std::cos(a), d.v - 20 * std::sin(a)}, robot->heightMm);
      if (q0 && q1) {
        p["x_mm"] = q0->x;
        p["y_mm"] = q0->y;
        p["z_mm"] = q0->z;
        p["rz_deg"] = std::remainder(std::atan2(q1->y - q0->y, q1->x - q0->x) / kDegToRad, 360.0);
      }
    }
    j["parts"].push_back(p);
  }
  if (o.json) {
    std::printf("%s\n", j.dump().c_str());
  } else {
    std::printf("%s: %zu part(s) in %.1f ms (%s)\n", o.image.c_str(), out->parts.size(), ms, method.c_str());
    for (const auto& d : out->parts)
      std::printf("  x %.2f px  y %.2f px  angle %.2f deg  score %.3f\n", d.u, d.v, d.angleDeg, d.score);
  }
  return 0;
}

int runEval(const EvalOptions& o, bool json) {
  auto rep = evaluate(o);
  if (!rep) return errorOut(rep.error().message);
  if (!o.plotPath.empty())
    if (auto p = plotErrors(*rep, o, o.plotPath); !p) return errorOut(p.error().message);
  if (!json) {
    std::printf("%s on %s: %d samples (%d parts, %d empty images), success %.1f %% at <= %.2f px / <= %.2f deg\n",
                rep->method.c_str(), o.datasetFolder.c_str(), rep->n, rep->parts, rep->emptyImages, 100 * rep->successRate(),
                o.posTolPx, o.angTolDeg);
  }
  std::printf("%s\n", evalJson(*rep, o).c_str());
  return 0;
}

}  // namespace

struct LocateCommands::State {
  CLI::App* render = nullptr;
  CLI::App* teach = nullptr;
  CLI::App* locate = nullptr;
  CLI::App* eval = nullptr;
  sim::DatasetOptions dataset;
  TeachOptions teachOpts;
  LocateOptions locateOpts;
  EvalOptions evalOpts;
  bool evalJson = false;
};

LocateCommands::LocateCommands(CLI::App& app) : state_(std::make_unique<State>()) {
  State& s = *state_;
  auto* simCmd = app.add_subcommand("sim", "simulation tools");
  simCmd->require_subcommand(1);
  s.render = simCmd->add_subcommand("render", "write a localization dataset with ground truth (docs/datasets.md)");
  auto& d = s.dataset;
  s.render->add_option("--out", d.outDir, "output folder")->required();
  s.render->add_option("--count", d.count, "images")->check(CLI::Range(1, 1000000));
  s.render->add_option("--seed", d.scene.seed, "scene seed");
  s.render->add_option("--part", d.part, "flat or multi")->check(CLI::IsMember({"flat", "multi"}));
  s.render->add_option("--levels", d.levels, "height levels of the multi part")->check(CLI::Range(2, 4));
  s.render->add_option("--angle-range", d.scene.angleRangeDeg, "rotation drawn in [-DEG, DEG] (180 = full turn)")->check(CLI::Range(0.0, 180.0));
  s.render->add_option("--noise", d.scene.noiseSigma, "Gaussian noise sigma, gray levels")->check(CLI::Range(0.0, 64.0));
  s.render->add_option("--blur", d.scene.blurSigma, "Gaussian blur sigma, px")->check(CLI::Range(0.0, 10.0));
  s.render->add_option("--illum-ratio", d.scene.illumRatio, "lighting gradient, brightest : darkest (1 = even)")->check(CLI::Range(1.0, 10.0));
  s.render->add_option("--clutter", d.scene.clutter, "distractor shapes per image")->check(CLI::Range(0, 64));
  s.render->add_option("--decoys", d.scene.decoys, "pieces of the part's own faces lying on the belt, per image")->check(CLI::Range(0, 16));
  s.render->add_option("--parts", d.scene.partsPerImage, "parts per non-empty image")->check(CLI::Range(1, 16));
  s.render->add_option("--empty-ratio", d.scene.emptyRatio, "share of images without a part")->check(CLI::Range(0.0, 1.0));
  s.render->add_option("--width", d.scene.width, "image width, px")->check(CLI::Range(64, 2448));
  s.render->add_option("--height", d.scene.height, "image height, px")->check(CLI::Range(64, 2048));
  s.render->add_option("--camera-height", d.scene.cameraHeightMm, "camera above the conveyor, mm")->check(CLI::Range(100.0, 5000.0));
  s.render->add_option("--focal", d.scene.focalPx, "focal length, px (0 = 1000 * width / 1280)")->check(CLI::Range(0.0, 100000.0));

  auto& t = s.teachOpts;
  s.teach = app.add_subcommand("teach", "create a job folder from a template image (docs/localization.md)");
  s.teach->add_option("--image", t.image, "template image (the part as taught)")->required();
  s.teach->add_option("--grasp", t.grasps, "grasp point X,Y in template px (repeat for more; the first is located)")->required();
  s.teach->add_option("--roi", t.roi, "search region X,Y,W,H in live images (default: whole image)");
  s.teach->add_option("--method", t.method, "locate method");
  s.teach->add_option("--param", t.params, "method parameter NAME=VALUE (repeatable)");
  s.teach->add_option("--regions", t.regionsFile, "YAML file with a 'regions' list (e.g. a dataset's template.yaml)");
  s.teach->add_flag("!--no-auto-regions", t.autoRegions, "do not split regions from the template's contours");
  s.teach->add_option("--min-score", t.minScore, "[0, 1]")->check(CLI::Range(0.0, 1.0));
  s.teach->add_option("--max-parts", t.maxParts, "[1, 64]")->check(CLI::Range(1, 64));
  s.teach->add_option("--angle-min", t.angleMin, "deg")->check(CLI::Range(-180.0, 180.0));
  s.teach->add_option("--angle-max", t.angleMax, "deg")->check(CLI::Range(-180.0, 180.0));
  s.teach->add_option("--part-height", t.partHeightMm, "grasp height above the conveyor, mm")->check(CLI::Range(0.0, 1000.0));
  s.teach->add_option("--name", t.name, "job name (default: the folder name)");
  s.teach->add_option("--out", t.out, "job folder to create")->required();

  auto& l = s.locateOpts;
  s.locate = app.add_subcommand("locate", "run a job's method on one image");
  s.locate->add_option("--job", l.job, "job folder")->required();
  s.locate->add_option("--image", l.image, "image file")->required();
  s.locate->add_option("--method", l.method, "override the job's method");
  s.locate->add_flag("--json", l.json, "one JSON object: status, time_ms, parts");

  auto& e = s.evalOpts;
  s.eval = app.add_subcommand("eval", "run a job's method over a dataset and score it (docs/localization.md)");
  s.eval->add_option("--job", e.jobFolder, "job folder")->required();
  s.eval->add_option("--dataset", e.datasetFolder, "dataset folder (truth.csv)")->required();
  s.eval->add_option("--method", e.method, "override the job's method");
  s.eval->add_option("--pos-tol", e.posTolPx, "success: position error <= PX")->check(CLI::Range(0.0, 1e6));
  s.eval->add_option("--ang-tol", e.angTolDeg, "success: angle error <= DEG")->check(CLI::Range(0.0, 180.0));
  s.eval->add_option("--match-tol", e.matchTolPx, "a feature match is correct within PX of its true place")->check(CLI::Range(0.0, 1e6));
  s.eval->add_option("--limit", e.limit, "first N images only")->check(CLI::Range(0, 100000000));
  s.eval->add_option("--plot", e.plotPath, "PNG of the sorted error curves (paper 000, Fig. 7)");
  s.eval->add_flag("--json", s.evalJson, "only the final JSON line");
}

LocateCommands::~LocateCommands() = default;

int LocateCommands::run() {
  State& s = *state_;
  if (*s.render) return runSimRender(s.dataset);
  if (*s.teach) return runTeach(s.teachOpts);
  if (*s.locate) return runLocate(s.locateOpts);
  if (*s.eval) return runEval(s.evalOpts, s.evalJson);
  return -1;
}

}  // namespace vgr::daemon
