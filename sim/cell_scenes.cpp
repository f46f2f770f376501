#include "sim/cell_scenes.hpp"

#include <cmath>

#include <fmt/format.h>
#include <opencv2/core.hpp>

#include "config/cell_config.hpp"
#include "core/angles.hpp"

namespace vgr::sim {
namespace {
constexpr double kDegToRad = M_PI / 180.0;
}  // namespace

CellScenes::CellScenes(const config::CellConfig& cell)
    : mode_(cell.sim.scene), planeZ_(cell.model.planeZ), still_(cell.sim.still), labelled_(!cell.sim.classes.empty()) {
  if (mode_ == "plate")
    plate_ = std::make_unique<SceneRenderer>(SceneRenderer::fromCellConfig(cell));
  else
    parts_ = std::make_unique<PartSceneRenderer>(PartSceneRenderer::fromCellConfig(cell));
}

int CellScenes::width() const { return plate_ ? plate_->options().width : parts_->options().width; }
int CellScenes::height() const { return plate_ ? plate_->options().height : parts_->options().height; }

namespace {

CellPartTruth fromPlate(const SceneTruth& t) { return {t.xMm, t.yMm, t.zMm, t.rzDeg, t.uPx, t.vPx, t.angleImgDeg}; }

CellPartTruth fromPlaced(const PartSceneRenderer& r, const PlacedPart& p, double planeZ, bool labelled) {
  const double c = std::cos(p.rzDeg * kDegToRad), s = std::sin(p.rzDeg * kDegToRad);
  const PartModel& model = *r.classes().at(static_cast<std::size_t>(p.classIndex));  // its own class's grasp point
  const PointMm g = model.grasp;
  CellPartTruth t;
  t.label = labelled ? p.classIndex + 1 : 0;
  t.xMm = p.xMm + c * g.x - s * g.y;
  t.yMm = p.yMm + s * g.x + c * g.y;
  t.zMm = planeZ + model.graspHeightMm;
  t.rzDeg = p.rzDeg;
  t.uPx = p.uPx;
  t.vPx = p.vPx;
  // The part's +x axis in the image: its rotation from the template plus the template's
  // own axis (rz = 0), which is the base +x axis seen by the camera.
  const auto a = r.camera().project({t.xMm, t.yMm, t.zMm});
  const auto b = r.camera().project({t.xMm + 10 * c, t.yMm + 10 * s, t.zMm});
  t.angleImgDeg = (a && b) ? normaliseDeg(std::atan2(-(b->v - a->v), b->u - a->u) / kDegToRad) : 0.0;
  return t;
}

}  // namespace

std::vector<CellPartTruth> CellScenes::truth(std::uint64_t frameId) const {
  if (plate_) return {fromPlate(plate_->truthForFrame(frameId))};
  std::vector<CellPartTruth> out;
  for (const auto& p : parts_->sample(still_ ? 1 : frameId).parts) out.push_back(fromPlaced(*parts_, p, planeZ_, labelled_));
  return out;
}

std::vector<CellPartTruth> CellScenes::render(std::uint64_t frameId, cv::Mat& dst) const {
  if (plate_) return {fromPlate(plate_->render(frameId, dst))};
  const PartScene scene = parts_->sample(still_ ? 1 : frameId);
  parts_->render(scene, dst, frameId);
  std::vector<CellPartTruth> out;
  for (const auto& p : scene.parts) out.push_back(fromPlaced(*parts_, p, planeZ_, labelled_));
  return out;
}

std::string CellScenes::truthJson(std::uint64_t frameId, const std::vector<CellPartTruth>& parts) {
  auto fields = [](const CellPartTruth& t) {
    return fmt::format(R"("x_mm":{:.4f},"y_mm":{:.4f},"z_mm":{:.4f},"rz_deg":{:.4f},"u_px":{:.4f},"v_px":{:.4f},"angle_img_deg":{:.4f})",
                       t.xMm, t.yMm, t.zMm, t.rzDeg, t.uPx, t.vPx, t.angleImgDeg);
  };
  std::string s = fmt::format(R"({{"frame_id":{})", frameId);
  if (!parts.empty()) s.append(",").append(fields(parts.front()));
  s.append(R"(,"parts":[)");
  for (std::size_t i = 0; i < parts.size(); ++i) {
    s.append(i ? ",{" : "{").append(fields(parts[i]));
    if (parts[i].label > 0) s.append(fmt::format(R"(,"label":{})", parts[i].label));
    s.append("}");
  }
  s.append("]}");
  return s;
}

double baseXAxisImageAngleDeg(const config::CellConfig& cell) {
  const auto& m = cell.model;
  const vision::PinholePlaneModel cam(m.fx, m.fy, m.cx, m.cy,
                                      vision::PinholePlaneModel::downLookingCamera(m.camX, m.camY, m.camZ, m.camRzDeg),
                                      m.planeZ);
  const auto a = cam.project({m.camX, m.camY, m.planeZ});
  const auto b = cam.project({m.camX + 10, m.camY, m.planeZ});
  return normaliseDeg(std::atan2(-(b->v - a->v), b->u - a->u) / kDegToRad);
}

}  // namespace vgr::sim
