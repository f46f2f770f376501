#include "tools/vgr/calibrate_common.hpp"

#include <unistd.h>

#include <algorithm>
#include <cstdio>
#include <filesystem>

#include <CLI/CLI.hpp>
#include <fmt/core.h>

namespace vgr::tools {
namespace calib = vision::calib;

void addPatternOptions(CLI::App& c, CalibPatternOptions& p) {
  c.add_option("--pattern", p.pattern, "chessboard, circles (symmetric grid) or charuco");
  c.add_option("--cols", p.cols, "inner corners (chessboard, charuco: squares - 1) / circles per row");
  c.add_option("--rows", p.rows, "inner corners (chessboard, charuco: squares - 1) / circles per column");
  c.add_option("--square", p.squareMm, "square size / circle spacing, mm");
  c.add_option("--marker", p.markerMm, "charuco: ArUco marker side, mm (default 0.75 x square)");
  c.add_option("--dict", p.dictionary, "charuco: ArUco dictionary, e.g. DICT_5X5_100 (default), DICT_4X4_50, DICT_6X6_250");
}

Result<calib::PatternSpec> patternSpec(const CalibPatternOptions& o) {
  auto kind = calib::parsePatternKind(o.pattern);
  if (!kind) return std::unexpected(kind.error());
  calib::PatternSpec spec{*kind, o.cols, o.rows, o.squareMm};
  spec.markerMm = o.markerMm > 0 ? o.markerMm : 0.75 * o.squareMm;
  spec.dictionary = o.dictionary;
  if (auto v = calib::validatePatternSpec(spec); !v) return std::unexpected(v.error());
  return spec;
}

void progress(std::size_t i, std::size_t n, const std::string& name, const std::string& status) {
  const int width = 20;
  const int done = static_cast<int>(static_cast<double>(i) * width / static_cast<double>(std::max<std::size_t>(n, 1)));
  std::fprintf(stderr, "[%s%s] %3zu/%zu %s: %s\n", std::string(static_cast<std::size_t>(done), '#').c_str(),
               std::string(static_cast<std::size_t>(width - done), '-').c_str(), i, n, name.c_str(), status.c_str());
}

int bad(const std::string& msg) {
  std::fprintf(stderr, "vgr calibrate: %s\n", msg.c_str());
  return 2;
}

Result<void> checkOutputPath(const std::string& path, const std::string& option) {
  namespace fs = std::filesystem;
  std::error_code ec;
  if (path.empty()) return fail(Status::BadArgument, option + ": expected a file path");
  if (fs::is_directory(path, ec)) return fail(Status::BadArgument, fmt::format("{} {}: is a folder, expected a file", option, path));
  fs::path dir = fs::path(path).parent_path();
  if (dir.empty()) dir = ".";
  if (!fs::is_directory(dir, ec))
    return fail(Status::BadArgument, fmt::format("{} {}: the folder {} does not exist", option, path, dir.string()));
  if (::access(dir.c_str(), W_OK | X_OK) != 0 || (fs::exists(path, ec) && ::access(path.c_str(), W_OK) != 0))
    return fail(Status::BadArgument, fmt::format("{} {}: not writable", option, path));
  return {};
}

int implausible(const std::string& what, const std::string& why, const std::string& hint) {
  std::fprintf(stderr, "vgr calibrate: implausible %s: %s; nothing written. %s\n", what.c_str(), why.c_str(), hint.c_str());
  return 1;
}

}  // namespace vgr::tools
