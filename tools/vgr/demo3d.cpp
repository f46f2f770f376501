#include "tools/vgr/demo3d.hpp"

#include <filesystem>
#include <fstream>

#include <fmt/core.h>
#include <nlohmann/json.hpp>

#include "config/cell_config.hpp"
#include "config/job3d.hpp"
#include "sim/depth_dataset.hpp"
#include "tools/vgr/calibrate_handeye.hpp"

namespace vgr::tools {
namespace fs = std::filesystem;

Result<std::string> prepareDemo3d(const std::string& work, int scenes, std::uint64_t seed, const Demo3dScenes& choice) {
  const fs::path dir(work);
  std::error_code ec;
  for (const char* sub : {"sim-calib-3d", "sim-job-3d"}) fs::create_directories(dir / sub, ec);
  if (ec) return fail(Status::BadArgument, work + ": " + ec.message());
  const std::pair<const char*, const std::string*> files[] = {
      {"sim-cell-3d.yaml", &config::embeddedSimCell3dYaml()},
      {"sim-calib-3d/handeye.yaml", &config::embeddedSimCalib3dHandEye()},
      {"sim-calib-3d/truth.yaml", &config::embeddedSimCalib3dTruth()},
      {"sim-job-3d/job.yaml", &config::embeddedSimJob3dYaml()}};
  for (const auto& [name, text] : files) {
    std::ofstream out(dir / name);
    out << *text;
    if (!out) return fail(Status::BadArgument, (dir / name).string() + ": cannot write");
  }
  // The scenes the depth emulator serves (frame k shows scene (k - 1) mod count).
  sim::DepthDatasetOptions d;
  d.outDir = (dir / "scenes").string();
  d.count = scenes;
  d.views = 0;
  d.scene.part = choice.part;
  d.scene.clutter = choice.clutter;
  d.scene.tiltMaxDeg = choice.tiltMaxDeg;
  d.scene.face = choice.face;
  d.scene.bin = choice.bin;
  d.scene.cameraTiltMaxDeg = choice.cameraTiltMaxDeg;
  d.scene.emptyRatio = choice.emptyRatio;
  d.scene.occlusion = choice.occlusion;
  d.scene.seed = seed;
  if (auto w = sim::writeDepthDataset(d); !w) return std::unexpected(w.error());
  fs::copy_file(dir / "scenes" / "model.ply", dir / "sim-job-3d" / "model.ply", fs::copy_options::overwrite_existing, ec);
  if (ec) return fail(Status::BadArgument, (dir / "sim-job-3d/model.ply").string() + ": " + ec.message());
  return (dir / "sim-cell-3d.yaml").string();
}

Result<Truth3d> Truth3d::load(const std::string& work, const std::string& truthJsonl) {
  Truth3d t;
  const std::string truthYaml = (fs::path(work) / "sim-calib-3d" / "truth.yaml").string();
  auto x = readHandEyeTruth(truthYaml);
  if (!x) return std::unexpected(x.error());
  if (!*x || (*x)->config != vision::calib::HandEyeConfig::EyeToHand)
    return fail(Status::BadArgument, truthYaml + ": expected the eye-to-hand truth X = T_base_cam");
  t.baseFromCamera_ = (*x)->x;
  auto job = config::loadJob3d((fs::path(work) / "sim-job-3d").string());
  if (!job) return std::unexpected(job.error());
  t.modelFromGrasp_ = job->grasp;
  std::ifstream in(truthJsonl);
  if (!in) return fail(Status::BadArgument, truthJsonl + ": cannot open the emulator's truth");
  int lineNo = 0;
  for (std::string line; std::getline(in, line);) {
    ++lineNo;
    try {
      const auto j = nlohmann::json::parse(line);
      std::vector<Pose>& parts = t.camFromModel_[j.at("frame_id").get<std::uint64_t>()];
      parts.clear();
      for (const auto& p : j.at("parts"))
        parts.push_back(poseFromQuaternion(p.at("x_mm"), p.at("y_mm"), p.at("z_mm"), p.at("qw"), p.at("qx"), p.at("qy"), p.at("qz")));
    } catch (const nlohmann::json::exception& e) {
      return fail(Status::BadArgument, fmt::format("{}:{}: {}", truthJsonl, lineNo, e.what()));
    }
  }
  return t;
}

std::vector<Pose> Truth3d::baseGrasps(std::uint64_t frameId) const {
  std::vector<Pose> out;
  const auto it = camFromModel_.find(frameId);
  if (it == camFromModel_.end()) return out;
  for (const Pose& camFromModel : it->second) out.push_back(compose(compose(baseFromCamera_, camFromModel), modelFromGrasp_));
  return out;
}

}  // namespace vgr::tools
