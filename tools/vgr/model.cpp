#include "tools/vgr/model.hpp"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "config/depth_dataset.hpp"
#include "config/job3d.hpp"
#include "tools/vgr/calibrate_common.hpp"  // progress()
#include "tools/vgr/teach.hpp"              // writeNew3dJob()
#include "vision/cloud/model_builder.hpp"
#include "vision/depth_image.hpp"
#include "vision/ply_file.hpp"

namespace vgr::tools {

namespace fs = std::filesystem;

namespace {

double r3(double v) { return std::round(v * 1000) / 1000; }

nlohmann::ordered_json reportJson(const vision::cloud::ModelBuildResult& r) {
  nlohmann::ordered_json views = nlohmann::ordered_json::array(), edges = nlohmann::ordered_json::array();
  for (const auto& v : r.views)
    views.push_back({{"view", v.name}, {"points", v.points}, {"used", v.used}, {"pose_disagreement_mm", r3(v.poseDisagreementMm)},
                     {"fitness", r3(v.fitness)}, {"rmse_mm", r3(v.rmseMm)}, {"why", v.why}});
  for (const auto& e : r.edges)
    edges.push_back({{"source", r.views[static_cast<std::size_t>(e.source)].name},
                     {"target", r.views[static_cast<std::size_t>(e.target)].name}, {"odometry", e.odometry},
                     {"fitness", r3(e.fitness)}, {"rmse_mm", r3(e.rmseMm)}, {"disagreement_mm", r3(e.disagreementMm)},
                     {"kept", e.kept}, {"why", e.why}});
  return {{"views", views}, {"edges", edges}};
}

}  // namespace

int runModelBuild(const ModelBuildOptions& o) {
  // Everything is read and checked before anything is written.
  const fs::path viewsDir(o.views);
  const std::string csv = (viewsDir / "views.csv").string();
  const std::string cameraPath = (viewsDir.parent_path() / "camera.yaml").string();
  if (!fs::is_directory(viewsDir)) return badInput(o.views + ": no such folder (expected DIR/views with views.csv)");
  if (o.out.empty()) return badInput("--out: expected the job folder to create");
  if (fs::exists(o.out)) return badInput(o.out + ": already exists (a 3D job is written into a new folder)");
  auto camera = config::loadDepthCameraFile(cameraPath);
  if (!camera) return badInput(camera.error().message);
  auto rows = config::loadDepthViews(csv);
  if (!rows) return badInput(rows.error().message);
  std::vector<vision::cloud::ModelView> views;
  for (const auto& row : *rows) {
    const std::string path = (viewsDir / row.view).string();
    auto depth = vision::readDepthMm(path, camera->depthScaleMm, camera->width, camera->height);
    if (!depth) return badInput(depth.error().message);
    views.push_back({row.view, *depth, camera->intrinsics(), row.reported});
  }
  vision::cloud::ModelBuildParams p;
  p.viewVoxelMm = o.viewVoxelMm;
  p.modelVoxelMm = o.modelVoxelMm;
  p.maxPoseDisagreementMm = o.maxPoseDisagreementMm;
  p.minFitness = o.minFitness;
  p.threads = o.threads;
  auto built = vision::cloud::buildModel(views, p, [](int done, int total, const std::string& what) {
    if (done == total || what.rfind("pair", 0) != 0 || done % std::max(1, total / 10) == 0)
      progress(static_cast<std::size_t>(done), static_cast<std::size_t>(total), what, "done");
  });
  if (!built) {
    // Bad parameters or a view without a part are bad input; views that do not register
    // into a model are a failed build.
    const bool registration = built.error().message.find("could be registered") != std::string::npos;
    std::fprintf(stderr, "vgr model build: %s\n", built.error().message.c_str());
    return registration ? 1 : 2;
  }

  // The report.
  int kept = 0;
  for (const auto& e : built->edges) kept += e.kept ? 1 : 0;
  std::printf("views: %d of %zu used\n", built->viewsUsed, built->views.size());
  for (const auto& v : built->views)
    std::printf("  %-14s %5d points  %s  pose disagreement %5.2f mm%s\n", v.name.c_str(), v.points,
                v.used ? fmt::format("fitness {:.3f} RMSE {:.3f} mm", v.fitness, v.rmseMm).c_str() : "not used              ",
                v.poseDisagreementMm, v.why.empty() ? "" : ("  (" + v.why + ")").c_str());
  std::printf("edges: %d of %zu kept\n", kept, built->edges.size());
  for (const auto& e : built->edges)
    std::printf("  %s -> %s%s  fitness %.3f RMSE %.3f mm  moved %.2f mm  %s\n",
                built->views[static_cast<std::size_t>(e.source)].name.c_str(),
                built->views[static_cast<std::size_t>(e.target)].name.c_str(), e.odometry ? " (odometry)" : "", e.fitness,
                e.rmseMm, e.disagreementMm, e.kept ? "kept" : ("rejected: " + e.why).c_str());

  config::Job3dFile job;
  job.name = o.name.empty() ? fs::path(o.out).filename().string() : o.name;
  const nlohmann::ordered_json report = reportJson(*built);
  if (const int rc = writeNew3dJob(o.out, job, built->model, "the model", "vgr model build --views " + o.views,
                                   {{"model_report.json", report.dump(2) + "\n"}});
      rc != 0)
    return rc;
  std::printf("%s: 3D job '%s', model %zu points from %d views\n", o.out.c_str(), job.name.c_str(),
              built->model.points.size(), built->viewsUsed);
  if (o.json) {
    nlohmann::ordered_json j{{"out", o.out},           {"views", built->views.size()},
                             {"views_used", built->viewsUsed}, {"edges", built->edges.size()},
                             {"edges_kept", kept},     {"model_points", built->model.points.size()}};
    j["report"] = report;
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

int runModelEval(const ModelEvalOptions& o) {
  auto job = config::loadJob3d(o.job);
  if (!job) return badInput(job.error().message);
  auto model = vision::readPlyCloud(job->modelPath());
  if (!model) return badInput(model.error().message);
  auto mesh = vision::readPlyMesh(o.mesh);
  if (!mesh) return badInput(mesh.error().message);
  auto d = vision::cloud::modelToMeshDistance(*model, *mesh);
  if (!d) return badInput(d.error().message);
  std::printf("%s against %s: %d points, distance to the surface mean %.3f mm, p95 %.3f mm, max %.3f mm "
              "(after aligning the model by %.3f, %.3f, %.3f mm)\n",
              job->modelPath().c_str(), o.mesh.c_str(), d->points, d->meanMm, d->p95Mm, d->maxMm, d->alignment.x,
              d->alignment.y, d->alignment.z);
  if (o.json) {
    const nlohmann::ordered_json j{{"mean_mm", r3(d->meanMm)}, {"p95_mm", r3(d->p95Mm)}, {"max_mm", r3(d->maxMm)},
                                   {"points", d->points}};
    std::printf("%s\n", j.dump().c_str());
  }
  return 0;
}

CLI::App* ModelBuildCommand::add(CLI::App& parent) {
  auto& b = options_;
  auto* c = parent.add_subcommand("build", "a 3D job from depth views of the part alone (paper 004; docs/3d.md)");
  c->add_option("--views", b.views, "DIR/views: views.csv and the view images (DIR/camera.yaml the camera)")->required();
  c->add_option("--out", b.out, "3D job folder to create")->required();
  c->add_option("--name", b.name, "job name (default: the folder name)");
  c->add_option("--view-voxel", b.viewVoxelMm, "mm, per-view grid for the registration")->check(CLI::Range(0.1, 20.0));
  c->add_option("--model-voxel", b.modelVoxelMm, "mm, grid of the merged model")->check(CLI::Range(0.1, 20.0));
  c->add_option("--max-pose-disagreement", b.maxPoseDisagreementMm,
                "mm: a view registered farther than this from its reported pose is left out")
      ->check(CLI::Range(0.1, 1000.0));
  c->add_option("--min-fitness", b.minFitness, "[0, 1]: share of a view that must overlap another for an edge")
      ->check(CLI::Range(0.0, 1.0));
  c->add_option("--threads", b.threads, "Open3D threads [1, 64]")->check(CLI::Range(1, 64));
  c->add_flag("--json", b.json, "end with one JSON line (the report included)");
  return c;
}

CLI::App* ModelEvalCommand::add(CLI::App& parent) {
  auto& e = options_;
  auto* c = parent.add_subcommand("eval", "distance of a 3D job's model to the true surface (mesh.ply)");
  c->add_option("--job", e.job, "3D job folder")->required();
  c->add_option("--mesh", e.mesh, "ASCII PLY triangle mesh of the part in the model frame (mm)")->required();
  c->add_flag("--json", e.json, "end with one JSON line: mean_mm, p95_mm, max_mm, points");
  return c;
}

}  // namespace vgr::tools
