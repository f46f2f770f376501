#include "config/grasp_truth_file.hpp"

#include "config/csv_line.hpp"

#include <charconv>
#include <cmath>
#include <fstream>
#include <map>

#include <fmt/core.h>

namespace vgr::config {
namespace {

const char* const kColumns[] = {"image", "part",  "grasp",   "sample", "u_px", "v_px", "angle_deg",
                                "width_px", "jaw_px", "x_mm", "y_mm", "z_mm", "width_mm"};
constexpr std::size_t kNumColumns = sizeof(kColumns) / sizeof(kColumns[0]);


}  // namespace

std::string graspTruthCsvHeader() {
  std::string h;
  for (const char* c : kColumns) {
    if (!h.empty()) h += ',';
    h += c;
  }
  return h;
}

std::string graspTruthCsvRow(const GraspTruthRow& r) {
  if (!r.hasGrasp) return r.image + std::string(kNumColumns - 1, ',');
  return fmt::format("{},{},{},{},{:.3f},{:.3f},{:.3f},{:.3f},{:.3f},{:.4f},{:.4f},{:.4f},{:.3f}", r.image, r.part, r.grasp, r.sample, r.u,
                     r.v, r.angleDeg, r.widthPx, r.jawPx, r.xMm, r.yMm, r.zMm, r.widthMm);
}

Result<std::vector<GraspTruthRow>> loadGraspTruth(const std::string& path) {
  std::ifstream in(path);
  if (!in) return fail(Status::BadArgument, path + ": cannot open");
  std::string line;
  if (!std::getline(in, line) || splitCsvLine(line) != splitCsvLine(graspTruthCsvHeader()))
    return fail(Status::BadArgument, fmt::format("{}:1: the header must be {}", path, graspTruthCsvHeader()));
  std::vector<GraspTruthRow> rows;
  std::map<std::string, std::pair<bool, bool>> seen;  // image -> (empty row, grasp row)
  int n = 1;
  while (std::getline(in, line)) {
    ++n;
    if (line.empty() || line == "\r") continue;
    const auto f = splitCsvLine(line);
    const std::string where = fmt::format("{}:{}", path, n);
    if (f.size() != kNumColumns) return fail(Status::BadArgument, fmt::format("{}: expected {} fields, got {}", where, kNumColumns, f.size()));
    GraspTruthRow r;
    r.image = f[0];
    r.line = n;
    if (r.image.empty()) return fail(Status::BadArgument, where + ": column 'image' is empty");
    bool allEmpty = true;
    for (std::size_t i = 1; i < kNumColumns; ++i) allEmpty = allEmpty && f[i].empty();
    auto& s = seen[r.image];
    if (allEmpty) {
      s.first = true;
    } else {
      r.hasGrasp = true;
      s.second = true;
      auto integer = [&](std::size_t i, int& v) -> Result<void> {
        const auto res = std::from_chars(f[i].data(), f[i].data() + f[i].size(), v);
        if (f[i].empty() || res.ec != std::errc() || res.ptr != f[i].data() + f[i].size() || v < 0)
          return fail(Status::BadArgument, fmt::format("{}: column '{}': expected an integer >= 0, got '{}'", where, kColumns[i], f[i]));
        return {};
      };
      auto number = [&](std::size_t i, double& v) -> Result<void> {
        const auto res = std::from_chars(f[i].data(), f[i].data() + f[i].size(), v);
        if (f[i].empty() || res.ec != std::errc() || res.ptr != f[i].data() + f[i].size() || !std::isfinite(v))
          return fail(Status::BadArgument, fmt::format("{}: column '{}': expected a number, got '{}'", where, kColumns[i], f[i]));
        return {};
      };
      if (auto e = integer(1, r.part); !e) return std::unexpected(e.error());
      r.grasp = f[2];
      if (r.grasp.empty()) return fail(Status::BadArgument, where + ": column 'grasp' is empty");
      if (auto e = integer(3, r.sample); !e) return std::unexpected(e.error());
      double* nums[] = {&r.u, &r.v, &r.angleDeg, &r.widthPx, &r.jawPx, &r.xMm, &r.yMm, &r.zMm, &r.widthMm};
      for (std::size_t i = 0; i < 9; ++i)
        if (auto e = number(4 + i, *nums[i]); !e) return std::unexpected(e.error());
      if (!(r.angleDeg > -90 && r.angleDeg <= 90))
        return fail(Status::BadArgument, fmt::format("{}: column 'angle_deg': {} is outside (-90, 90]", where, r.angleDeg));
      if (!(r.widthPx > 0) || !(r.jawPx > 0) || !(r.zMm > 0) || !(r.widthMm > 0))
        return fail(Status::BadArgument, where + ": width_px, jaw_px, z_mm and width_mm must be > 0");
    }
    if (s.first && s.second)
      return fail(Status::BadArgument, fmt::format("{}: image '{}' has both an empty row and grasp rows", where, r.image));
    rows.push_back(std::move(r));
  }
  if (rows.empty()) return fail(Status::BadArgument, path + ": no rows after the header");
  return rows;
}

}  // namespace vgr::config
