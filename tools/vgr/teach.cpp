#include "tools/vgr/teach.hpp"

#include <unistd.h>

#include <cmath>
#include <cstdio>
#include <exception>
#include <filesystem>
#include <fstream>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <opencv2/core.hpp>
#include <opencv2/imgcodecs.hpp>

#include "config/job.hpp"
#include "config/job3d.hpp"
#include "vision/cloud/locator3d.hpp"
#include "vision/gray_image.hpp"
#include "vision/locate/locator.hpp"
#include "vision/locate/regions.hpp"
#include "vision/ply_file.hpp"

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

namespace {

int runTeach3d(const TeachOptions& o) {
  namespace fs = std::filesystem;
  if (!o.image.empty() || !o.grasps.empty() || !o.roi.empty() || !o.regionsFile.empty() || !o.params.empty() || !o.polarity.empty())
    return badInput("--model makes a 3D job: --image, --grasp, --roi, --regions, --param and --polarity are for 2D jobs");
  auto cloud = vision::readPlyCloud(o.model);
  if (!cloud) return badInput(cloud.error().message);
  config::Job3dFile job;
  job.name = o.name.empty() ? fs::path(o.out).filename().string() : o.name;
  job.search.maxParts = o.maxParts;
  if (!o.graspPose.empty()) {
    std::vector<double> v;
    if (!parseNumbers(o.graspPose, 7, v))
      return badInput(fmt::format("--grasp-pose: expected X,Y,Z,QW,QX,QY,QZ (mm, unit quaternion), got '{}'", o.graspPose));
    const double n = std::sqrt(v[3] * v[3] + v[4] * v[4] + v[5] * v[5] + v[6] * v[6]);
    if (std::abs(n - 1) > 1e-3) return badInput(fmt::format("--grasp-pose: the quaternion is not unit length (|q| = {:.6f})", n));
    job.grasp = {v[0], v[1], v[2], v[3] / n, v[4] / n, v[5] / n, v[6] / n};
  }
  if (const int rc = writeNew3dJob(o.out, job, *cloud, o.model, "vgr teach --model " + o.model); rc != 0) return rc;
  std::printf("%s: 3D job '%s', model %zu points\n", o.out.c_str(), job.name.c_str(), cloud->points.size());
  return 0;
}

}  // namespace

int writeNew3dJob(const std::string& out, config::Job3dFile job, const vision::PlyCloud& cloud, const std::string& modelName,
                  const std::string& comment,
                  const std::vector<std::pair<std::string, std::string>>& extraFiles) {
  namespace fs = std::filesystem;
  // The locator must accept the model (normals, size) before anything is written.
  if (auto loc = vision::cloud::makeLocator3d(cloud, job.grasp, job.search); !loc)
    return badInput(modelName + ": " + loc.error().message);
  if (fs::exists(out)) return badInput(out + ": already exists (a 3D job is written into a new folder)");
  const fs::path tmp = fs::path(out).string() + fmt::format(".partial-{}", ::getpid());
  std::error_code ec;
  fs::remove_all(tmp, ec);
  fs::create_directories(tmp, ec);
  if (ec) return badInput(fmt::format("{}: cannot create: {}", tmp.string(), ec.message()));
  job.folder = tmp.string();
  auto cleanUp = [&](const std::string& why) {
    fs::remove_all(tmp, ec);
    return badInput(why);
  };
  if (auto w = vision::writePlyCloud(job.modelPath(), cloud, comment); !w) return cleanUp(w.error().message);
  if (auto w = config::writeJob3d(job); !w) return cleanUp(w.error().message);
  for (const auto& [name, text] : extraFiles) {
    std::ofstream f(tmp / name);
    f << text;
    if (!f.flush()) return cleanUp((tmp / name).string() + ": cannot write");
  }
  auto back = config::loadJob3d(tmp.string());  // what was written must load
  if (!back) return cleanUp("written job does not load: " + back.error().message);
  if (auto m = vision::readPlyCloud(back->modelPath()); !m || m->points.size() != cloud.points.size())
    return cleanUp(back->modelPath() + ": written model does not read back");
  fs::rename(tmp, out, ec);
  if (ec) return cleanUp(fmt::format("{}: cannot rename to {}: {}", tmp.string(), out, ec.message()));
  return 0;
}

int runTeach(const TeachOptions& o) {
  namespace fs = std::filesystem;
  if (!o.model.empty()) return runTeach3d(o);
  if (o.image.empty()) return badInput("--image is required (or --model for a 3D job)");
  if (o.grasps.empty()) return badInput("--grasp is required with --image");
  auto read = vision::readGray8(o.image);
  if (!read) return badInput(read.error().message);
  const cv::Mat img = *read;
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
  job.taught.scaleMin = o.scaleMin;
  job.taught.scaleMax = o.scaleMax;
  if (o.scaleMax < o.scaleMin) return badInput("--scale-max must not be below --scale-min");
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
  teachCmd->add_option("--image", t.image, "template image (the part as taught; 2D job)");
  teachCmd->add_option("--grasp", t.grasps, "grasp point X,Y in template px (repeat for more; the first is located; 2D job)");
  teachCmd->add_option("--model", t.model, "3D job from this model cloud (PLY x y z nx ny nz, mm; docs/3d.md)");
  teachCmd->add_option("--grasp-pose", t.graspPose, "3D job: grasp pose in the model frame X,Y,Z,QW,QX,QY,QZ (default: the model frame)");
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
  teachCmd->add_option("--scale-min", t.scaleMin, "smallest scale searched, image px per template px (default 1)")
      ->check(CLI::Range(kMinPartScale, kMaxPartScale));
  teachCmd->add_option("--scale-max", t.scaleMax, "largest scale searched (default 1; a part seen larger is nearer the camera)")
      ->check(CLI::Range(kMinPartScale, kMaxPartScale));
  teachCmd->add_option("--part-height", t.partHeightMm, "grasp height above the conveyor, mm")->check(CLI::Range(0.0, 1000.0));
  teachCmd->add_option("--name", t.name, "job name (default: the folder name)");
  teachCmd->add_option("--out", t.out, "job folder to create")->required();
  return teachCmd;
}

}  // namespace vgr::tools
