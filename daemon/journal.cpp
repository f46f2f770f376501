#include "daemon/journal.hpp"

#include <cerrno>
#include <cmath>
#include <cstring>
#include <filesystem>

#include <nlohmann/json.hpp>

namespace vgr::daemon {

Journal::~Journal() {
  if (file_) std::fclose(file_);
}

Result<void> Journal::open(const std::string& path) {
  std::error_code ec;
  const auto parent = std::filesystem::path(path).parent_path();
  if (!parent.empty()) std::filesystem::create_directories(parent, ec);
  file_ = std::fopen(path.c_str(), "a");
  if (!file_) return fail(Status::BadArgument, "journal " + path + ": " + std::strerror(errno));
  return {};
}

namespace {
// + 0.0 turns -0.0 into 0.0: no "-0" in the journal.
double round3(double v) { return std::round(v * 1000.0) / 1000.0 + 0.0; }
}  // namespace

std::string Journal::toJson(const CycleResult& r) {
  nlohmann::json j;
  j["cycle"] = r.cycleId;
  j["time"] = std::chrono::duration_cast<std::chrono::milliseconds>(r.triggerTime.time_since_epoch()).count() / 1000.0;
  j["trigger"] = triggerSourceName(r.trigger);
  j["job"] = r.jobId;
  j["status"] = statusCode(r.status);
  j["status_name"] = std::string(statusName(r.status));
  j["frame_id"] = r.frameId;
  j["grab_ms"] = round3(r.grabMs);
  j["locate_ms"] = round3(r.locateMs);
  j["total_ms"] = round3(r.totalMs);
  nlohmann::json parts = nlohmann::json::array();
  for (const auto& p : r.parts) {
    const auto e = toEulerZyxDeg(p.pose);
    const auto o = toEulerZyxDeg(p.offset);
    parts.push_back({{"x_mm", round3(p.pose.x)}, {"y_mm", round3(p.pose.y)}, {"z_mm", round3(p.pose.z)},
                     {"rz_deg", round3(e.rz)}, {"ry_deg", round3(e.ry)}, {"rx_deg", round3(e.rx)},
                     {"dx_mm", round3(p.offset.x)}, {"dy_mm", round3(p.offset.y)}, {"drz_deg", round3(o.rz)},
                     {"u_px", round3(p.uPx)}, {"v_px", round3(p.vPx)}, {"angle_img_deg", round3(p.angleImgDeg)},
                     {"score", round3(p.score)}, {"label", p.label}});
  }
  j["parts"] = std::move(parts);
  return j.dump();
}

void Journal::append(const CycleResult& r) {
  if (!file_) return;
  const std::string line = toJson(r);
  std::fprintf(file_, "%s\n", line.c_str());
  std::fflush(file_);
}

}  // namespace vgr::daemon
