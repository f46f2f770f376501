#include "tools/vgr/grasp_dataset.hpp"

#include <filesystem>
#include <map>

#include <fmt/core.h>

#include "config/depth_dataset.hpp"
#include "vision/depth_image.hpp"

namespace vgr::tools {

Result<GraspDataset> loadGraspDataset(const std::string& folder) {
  namespace fs = std::filesystem;
  GraspDataset set;
  set.folder = folder;
  auto cam = config::loadDepthCameraFile((fs::path(folder) / "camera.yaml").string());
  if (!cam) return std::unexpected(cam.error());
  set.camera = {cam->width, cam->height, cam->fx, cam->fy, cam->cx, cam->cy};
  set.depthScaleMm = cam->depthScaleMm;
  const std::string csv = (fs::path(folder) / "grasps.csv").string();
  std::error_code ec;
  if (!fs::exists(csv, ec))
    return fail(Status::BadArgument, csv + ": cannot open (a grasp data set is made with `vgr sim render --3d --grasps`)");
  auto rows = config::loadGraspTruth(csv);
  if (!rows) return std::unexpected(rows.error());
  std::map<std::string, std::size_t> index;
  for (auto& r : *rows) {
    // A true rectangle's centre outside the camera's image is a data set for another camera.
    if (r.hasGrasp && !(r.u >= 0 && r.v >= 0 && r.u <= set.camera.width - 1 && r.v <= set.camera.height - 1))
      return fail(Status::BadArgument, fmt::format("{}:{}: grasp centre ({}, {}) px lies outside the {}x{} image of camera.yaml", csv, r.line, r.u,
                                                   r.v, set.camera.width, set.camera.height));
    auto [it, added] = index.emplace(r.image, set.images.size());
    if (added) set.images.push_back({r.image, {}});
    if (r.hasGrasp) set.images[it->second].grasps.push_back(std::move(r));
  }
  return set;
}

Result<vision::grasp::DepthFrame> loadGraspFrame(const GraspDataset& set, const GraspImage& image) {
  const std::string path = (std::filesystem::path(set.folder) / image.image).string();
  auto z = vision::readDepthMm(path, set.depthScaleMm, set.camera.width, set.camera.height);
  if (!z) return std::unexpected(z.error());
  return vision::grasp::DepthFrame{*z, set.camera, path};
}

std::vector<vision::grasp::TruthRect> truthRects(const GraspDataset& set, const GraspImage& image) {
  std::map<std::pair<int, std::string>, int> lines;
  std::vector<vision::grasp::TruthRect> out;
  for (const auto& g : image.grasps) {
    const auto key = std::make_pair(g.part, g.grasp);
    auto it = lines.emplace(key, static_cast<int>(lines.size())).first;
    out.push_back({{g.u, g.v, g.angleDeg, g.widthPx, g.jawPx}, g.zMm, set.camera.fx, it->second, g.sample});
  }
  return out;
}

}  // namespace vgr::tools
