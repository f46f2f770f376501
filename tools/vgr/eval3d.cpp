#include "tools/vgr/eval3d.hpp"

#include <time.h>

#include <array>
#include <chrono>
#include <cstdio>
#include <filesystem>
#include <map>
#include <vector>

#include <fmt/core.h>
#include <nlohmann/json.hpp>
#include <opencv2/core.hpp>

#include "config/depth_dataset.hpp"
#include "config/job3d.hpp"
#include "tools/vgr/subcommand.hpp"
#include "vision/cloud/eval3d.hpp"
#include "vision/cloud/locator3d.hpp"
#include "vision/depth_image.hpp"
#include "vision/ply_file.hpp"

namespace vgr::tools {
namespace {

double threadCpuMs() {
  timespec t{};
  clock_gettime(CLOCK_THREAD_CPUTIME_ID, &t);
  return static_cast<double>(t.tv_sec) * 1e3 + static_cast<double>(t.tv_nsec) / 1e6;
}

struct Image {
  std::string path;
  std::vector<Pose> truth;  // empty: an image without a part
};

}  // namespace

int runEval3d(const Eval3dCliOptions& o) {
  namespace fs = std::filesystem;
  auto job = config::loadJob3d(o.jobFolder);
  if (!job) return badInput(job.error().message);
  auto model = vision::readPlyCloud(job->modelPath());
  if (!model) return badInput(model.error().message);
  auto cam = config::loadDepthCameraFile((fs::path(o.datasetFolder) / "camera.yaml").string());
  if (!cam) return badInput(cam.error().message);
  auto rows = config::loadDepthTruth((fs::path(o.datasetFolder) / "truth.csv").string());
  if (!rows) return badInput(rows.error().message);
  // Images in the order truth.csv first names them, each with its parts.
  std::vector<Image> images;
  std::map<std::string, std::size_t> at;
  for (const auto& r : *rows) {
    auto [it, added] = at.emplace(r.image, images.size());
    if (added) images.push_back({(fs::path(o.datasetFolder) / r.image).string(), {}});
    if (r.hasPart) images[it->second].truth.push_back(r.pose);
  }
  if (o.limit > 0 && static_cast<int>(images.size()) > o.limit) images.resize(static_cast<std::size_t>(o.limit));
  if (images.empty()) return badInput(o.datasetFolder + "/truth.csv: no image");
  // Every image is read and checked before the first is located: a bad one is bad input.
  std::vector<cv::Mat> depth;
  for (const auto& im : images) {
    auto d = vision::readDepthMm(im.path, cam->depthScaleMm, cam->width, cam->height);
    if (!d) return badInput(d.error().message);
    depth.push_back(std::move(*d));
  }
  auto locator = vision::cloud::makeLocator3d(*model, job->grasp, job->search);
  if (!locator) return badInput(job->modelPath() + ": " + locator.error().message);

  std::vector<std::array<double, 3>> addPoints;
  const std::size_t step = std::max<std::size_t>(1, model->points.size() / 3000);
  for (std::size_t i = 0; i < model->points.size(); i += step) addPoints.push_back(model->points[i]);
  vision::cloud::Eval3dOptions eo;
  eo.transTolMm = o.transTolMm;
  eo.rotTolDeg = o.rotTolDeg;
  vision::cloud::Eval3dAccumulator acc(std::move(addPoints), eo);
  const vision::cloud::DepthIntrinsics k = cam->intrinsics();
  for (std::size_t i = 0; i < images.size(); ++i) {
    const double c0 = threadCpuMs();
    const auto w0 = std::chrono::steady_clock::now();
    auto r = (*locator)->locate(depth[i], k);
    const double wall = std::chrono::duration<double, std::milli>(std::chrono::steady_clock::now() - w0).count();
    const double cpu = threadCpuMs() - c0;
    if (!r) return badInput(images[i].path + ": " + r.error().message);
    acc.add(images[i].truth, *r, wall, cpu);
  }
  const auto s = acc.summary();
  if (!o.json)
    std::printf("3d job %s on %s: %d images (%d parts, %d empty), success %.1f %% at <= %.2f mm / <= %.2f deg, %d false poses\n",
                o.jobFolder.c_str(), o.datasetFolder.c_str(), s.images, s.parts, s.emptyImages, 100 * s.successRate(), o.transTolMm,
                o.rotTolDeg, s.falsePositives);
  nlohmann::ordered_json j;
  j["kind"] = "3d";
  j["images"] = s.images;
  j["parts"] = s.parts;
  j["empty_images"] = s.emptyImages;
  j["success_rate"] = s.successRate();
  j["trans_err_mm_mean"] = s.transErrMean;
  j["trans_err_mm_max"] = s.transErrMax;
  j["rot_err_deg_mean"] = s.rotErrMean;
  j["rot_err_deg_max"] = s.rotErrMax;
  j["add_mm_mean"] = s.addMean;
  j["missed"] = s.missed;
  j["false_positives"] = s.falsePositives;
  j["retries"] = s.retries;
  j["not_found"] = s.notFound;
  j["time_ms_median"] = s.timeMsMedian;
  j["cpu_ms_median"] = s.cpuMsMedian;
  j["time_ms_max"] = s.timeMsMax;
  j["trans_tol_mm"] = o.transTolMm;
  j["rot_tol_deg"] = o.rotTolDeg;
  std::printf("%s\n", j.dump().c_str());
  return 0;
}

}  // namespace vgr::tools
