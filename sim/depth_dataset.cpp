#include "sim/depth_dataset.hpp"

#include <filesystem>
#include <fstream>

#include <fmt/core.h>
#include <opencv2/imgcodecs.hpp>
#include <unistd.h>

#include "config/depth_dataset.hpp"
#include "config/grasp_truth_file.hpp"
#include "sim/grasp_truth.hpp"
#include "vision/ply_file.hpp"

namespace vgr::sim {
namespace {

namespace fs = std::filesystem;

std::string optionsYaml(const DepthDatasetOptions& o) {
  const auto& s = o.scene;
  const auto& v = o.viewOptions;
  std::string y = "# How this 3D data set was made (vgr sim render --3d, docs/3d.md); truth is in truth.csv.\n";
  y += fmt::format("part: {}\ncount: {}\nseed: {}\n", s.part, o.count, s.seed);
  y += fmt::format("parts_per_scene: {}\nempty_ratio: {}\nclutter: {}\ntilt_max_deg: {}\nbin: {}\n", s.partsPerScene, s.emptyRatio,
                   s.clutter, s.tiltMaxDeg, s.bin ? "true" : "false");
  y += fmt::format("floor_mm: {}\ncamera_tilt_max_deg: {}\nocclusion: {}\n", s.floorMm, s.cameraTiltMaxDeg, s.occlusion);
  y += fmt::format("sensor: {{noise_mm_at_500: {}, dropout: {}, jump_mm: {}, grazing_deg: {}}}\n", s.sensor.noiseMmAt500,
                   s.sensor.dropout, s.sensor.jumpMm, s.sensor.grazingDeg);
  y += fmt::format("views: {{count: {}, distance_mm: {}, elevation_low_deg: {}, elevation_high_deg: {}, pose_noise_mm: {}, "
                   "pose_noise_deg: {}, bad_view: {}, bad_view_mm: {}}}\n",
                   o.views, v.distanceMm, v.elevationLowDeg, v.elevationHighDeg, v.poseNoiseMm, v.poseNoiseDeg, v.badView, v.badViewMm);
  y += fmt::format("model_spacing_mm: {}\nmesh_edge_mm: {}\n", o.modelSpacingMm, o.meshEdgeMm);
  if (o.grasps) y += "grasps: true  # grasps.csv (docs/grasp.md)\n";
  return y;
}

Result<DepthDatasetSummary> writeInto(const DepthDatasetOptions& o, const fs::path& dir) {
  const auto& s = o.scene;
  auto part = depthPart(s.part);
  if (!part) return std::unexpected(part.error());
  std::error_code ec;
  fs::create_directories(dir / "images", ec);
  if (ec) return fail(Status::Internal, fmt::format("{}: cannot create: {}", dir.string(), ec.message()));

  config::DepthCameraFile cam{s.camera.width, s.camera.height, s.camera.fx, s.camera.fy, s.camera.cx, s.camera.cy, s.camera.depthScaleMm};
  if (auto w = config::writeDepthCameraFile((dir / "camera.yaml").string(), cam); !w) return std::unexpected(w.error());
  {
    std::ofstream y(dir / "dataset.yaml");
    y << optionsYaml(o);
    y.close();
    if (!y) return fail(Status::Internal, fmt::format("{}/dataset.yaml: cannot write", o.outDir));
  }

  vision::PlyCloud model;
  for (const auto& p : sampleSurface(*part, o.modelSpacingMm)) {
    model.points.push_back({p.x, p.y, p.z});
    model.normals.push_back({p.nx, p.ny, p.nz});
  }
  const std::string what = fmt::format("vgr sim render --3d: part {} in its model frame, mm", s.part);
  if (auto w = vision::writePlyCloud((dir / "model.ply").string(), model, what + ", exterior points + outward normals"); !w)
    return std::unexpected(w.error());
  const TriMesh ext = exteriorMesh(*part, o.meshEdgeMm);
  if (auto w = vision::writePlyMesh((dir / "mesh.ply").string(), {ext.vertices, ext.triangles}, what + ", exterior surface"); !w)
    return std::unexpected(w.error());

  DepthDatasetSummary sum;
  std::ofstream csv(dir / "truth.csv");
  csv << config::depthTruthCsvHeader() << ",part,face,pixels,visible_pixels\n";
  std::ofstream gcsv;
  if (o.grasps) {
    gcsv.open(dir / "grasps.csv");
    gcsv << config::graspTruthCsvHeader() << "\n";
  }
  for (int i = 0; i < o.count; ++i) {
    auto scene = renderDepthScene(s, static_cast<std::uint64_t>(i));
    if (!scene) return std::unexpected(scene.error());
    const std::string name = fmt::format("images/{:04d}.png", i);
    if (!cv::imwrite((dir / name).string(), scene->depth)) return fail(Status::Internal, fmt::format("{}/{}: cannot write", o.outDir, name));
    if (scene->parts.empty()) {
      csv << config::depthTruthCsvRow(name, nullptr) << ",-1,,,\n";
      ++sum.emptyImages;
    }
    for (std::size_t k = 0; k < scene->parts.size(); ++k) {
      const auto& t = scene->parts[k];
      csv << config::depthTruthCsvRow(name, &t.pose) << fmt::format(",{},{},{},{}\n", k, t.face, t.pixels, t.visiblePixels);
      ++sum.parts;
    }
    if (o.grasps) {
      auto truth = sceneGraspTruth(*scene, s.part);
      if (!truth) return std::unexpected(truth.error());
      config::GraspTruthRow r;
      r.image = name;
      if (truth->empty()) gcsv << config::graspTruthCsvRow(r) << "\n";
      for (const auto& g : *truth) {
        r.hasGrasp = true;
        r.part = g.part, r.grasp = g.grasp, r.sample = g.sample;
        r.u = g.u, r.v = g.v, r.angleDeg = g.angleDeg, r.widthPx = g.widthPx, r.jawPx = g.jawPx;
        r.xMm = g.centreCam.x, r.yMm = g.centreCam.y, r.zMm = g.centreCam.z, r.widthMm = g.widthMm;
        gcsv << config::graspTruthCsvRow(r) << "\n";
      }
    }
    ++sum.images;
  }
  csv.close();
  if (!csv) return fail(Status::Internal, fmt::format("{}/truth.csv: cannot write", o.outDir));
  if (o.grasps) {
    gcsv.close();
    if (!gcsv) return fail(Status::Internal, fmt::format("{}/grasps.csv: cannot write", o.outDir));
  }

  if (o.views > 0) {
    PartViewsOptions v = o.viewOptions;
    v.part = s.part;
    v.camera = s.camera;
    v.sensor = s.sensor;
    v.views = o.views;
    v.seed = s.seed;
    auto views = renderPartViews(v);
    if (!views) return std::unexpected(views.error());
    fs::create_directories(dir / "views", ec);
    if (ec) return fail(Status::Internal, fmt::format("{}/views: cannot create: {}", o.outDir, ec.message()));
    std::ofstream vcsv(dir / "views" / "views.csv");
    vcsv << config::depthViewsCsvHeader() << "\n";
    for (std::size_t k = 0; k < views->size(); ++k) {
      const std::string name = fmt::format("view_{:02d}.png", k);
      if (!cv::imwrite((dir / "views" / name).string(), (*views)[k].depth))
        return fail(Status::Internal, fmt::format("{}/views/{}: cannot write", o.outDir, name));
      vcsv << config::depthViewsCsvRow(name, (*views)[k].cameraInModel, (*views)[k].reported) << "\n";
      ++sum.views;
    }
    vcsv.close();
    if (!vcsv) return fail(Status::Internal, fmt::format("{}/views/views.csv: cannot write", o.outDir));
  }
  return sum;
}

}  // namespace

Result<DepthDatasetSummary> writeDepthDataset(const DepthDatasetOptions& o) {
  if (o.outDir.empty()) return fail(Status::BadArgument, "--out: expected a folder");
  if (o.count < 1 || o.count > 1000000) return fail(Status::BadArgument, "--count: expected 1..1000000");
  if (o.views < 0 || o.views > 72) return fail(Status::BadArgument, "--views: expected 0..72");
  if (!(o.modelSpacingMm > 0.1) || !(o.meshEdgeMm > 0.1)) return fail(Status::BadArgument, "model spacing and mesh edge: expected > 0.1 mm");
  // Check every option on the first scene (and the views) before creating anything.
  if (auto first = renderDepthScene(o.scene, 0); !first) return std::unexpected(first.error());
  const fs::path out(o.outDir);
  std::error_code ec;
  if (fs::exists(out, ec) && !(fs::is_directory(out, ec) && fs::is_empty(out, ec)))
    return fail(Status::BadArgument, fmt::format("{}: exists and is not an empty folder (nothing is overwritten: choose a new one)", o.outDir));
  const fs::path partial = out.string() + fmt::format(".partial-{}", ::getpid());
  fs::remove_all(partial, ec);
  auto sum = writeInto(o, partial);
  if (!sum) {
    fs::remove_all(partial, ec);
    return sum;
  }
  fs::remove(out, ec);  // the empty folder, if any
  fs::rename(partial, out, ec);
  if (ec) {
    fs::remove_all(partial, ec);
    return fail(Status::Internal, fmt::format("{}: cannot rename the written data set into place: {}", o.outDir, ec.message()));
  }
  return sum;
}

}  // namespace vgr::sim
