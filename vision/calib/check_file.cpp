#include "vision/calib/check_file.hpp"
#include "vision/calib/calib_file_guard.hpp"

#include <exception>
#include <cmath>
#include <filesystem>

#include <fmt/core.h>

namespace vgr::vision::calib {
namespace {

struct Bad {
  std::string message;
};

double number(const cv::FileNode& parent, const char* key, double lo, double hi, const std::string& where) {
  const cv::FileNode n = parent[key];
  if (n.empty() || (!n.isReal() && !n.isInt()))
    throw Bad{fmt::format("key '{}{}': expected a number in [{:g}, {:g}]", where, key, lo, hi)};
  const double v = static_cast<double>(n);
  if (!std::isfinite(v) || v < lo || v > hi)
    throw Bad{fmt::format("key '{}{}': expected a number in [{:g}, {:g}], got {:g}", where, key, lo, hi, v)};
  return v;
}

}  // namespace

Result<CheckFile> readCheckFile(const std::string& path) {
  if (!std::filesystem::exists(path)) return fail(Status::NotCalibrated, fmt::format("{}: no such check file", path));
  CheckFile c;
  try {
    requireYamlText(path);
    cv::FileStorage fs(path, cv::FileStorage::READ);
    if (!fs.isOpened()) return fail(Status::NotCalibrated, fmt::format("{}: cannot read it as OpenCV YAML", path));
    const cv::FileNode root = fs.root();
    if (static_cast<std::string>(root["calibration_kind"]) != "check")
      throw Bad{"key 'calibration_kind': expected 'check' (a file of vgr calibrate verify --store)"};
    c.toleranceMm = number(root, "tolerance_mm", 1e-6, 100, "");
    c.toleranceDeg = number(root, "tolerance_deg", 1e-6, 180, "");
    c.stored = static_cast<std::string>(root["stored"]);
    if (const cv::FileNode f = root["fiducial"]; !f.empty()) {
      c.fiducial.present = true;
      const std::vector<int> w = [&] {
        std::vector<int> v;
        f["window_px"] >> v;
        return v;
      }();
      if (w.size() != 4 || w[2] < 5 || w[3] < 5 || w[0] < 0 || w[1] < 0)
        throw Bad{"key 'fiducial.window_px': expected [x, y, width, height] px, width and height >= 5"};
      c.fiducial.window = cv::Rect(w[0], w[1], w[2], w[3]);
      c.fiducial.bright = static_cast<int>(f["bright"]) != 0;
      c.fiducial.heightMm = number(f, "height_mm", -1000, 1000, "fiducial.");
      std::vector<double> p;
      f["position_mm"] >> p;
      if (p.size() != 3 || !std::isfinite(p[0] + p[1] + p[2])) throw Bad{"key 'fiducial.position_mm': expected [x, y, z] mm"};
      c.fiducial.positionMm = {p[0], p[1], p[2]};
      c.fiducial.areaPx = number(f, "area_px", 0, 1e7, "fiducial.");
    }
    if (const cv::FileNode p = root["part"]; !p.empty()) {
      c.part.present = true;
      c.part.job = static_cast<int>(number(p, "job", 1, 32767, "part."));
      c.part.xMm = number(p, "x_mm", -1e6, 1e6, "part.");
      c.part.yMm = number(p, "y_mm", -1e6, 1e6, "part.");
      c.part.zMm = number(p, "z_mm", -1e6, 1e6, "part.");
      c.part.rzDeg = number(p, "rz_deg", -360, 360, "part.");
    }
    if (!c.fiducial.present && !c.part.present) throw Bad{"neither 'fiducial' nor 'part': nothing to check"};
  } catch (const Bad& b) {
    return fail(Status::NotCalibrated, fmt::format("{}: {}", path, b.message));
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::NotCalibrated, fmt::format("{}: {}", path, e.what()));
  }
  return c;
}

Result<void> writeCheckFile(const std::string& path, const CheckFile& c) {
  try {
    cv::FileStorage fs(path, cv::FileStorage::WRITE);
    if (!fs.isOpened()) return fail(Status::BadArgument, fmt::format("{}: cannot write", path));
    fs << "calibration_kind" << "check";
    fs << "stored" << c.stored;
    fs << "tolerance_mm" << c.toleranceMm << "tolerance_deg" << c.toleranceDeg;
    if (c.fiducial.present) {
      fs << "fiducial" << "{";
      fs << "window_px" << std::vector<int>{c.fiducial.window.x, c.fiducial.window.y, c.fiducial.window.width, c.fiducial.window.height};
      fs << "bright" << (c.fiducial.bright ? 1 : 0);
      fs << "height_mm" << c.fiducial.heightMm;
      fs << "position_mm" << std::vector<double>{c.fiducial.positionMm.x, c.fiducial.positionMm.y, c.fiducial.positionMm.z};
      fs << "area_px" << c.fiducial.areaPx;
      fs << "}";
    }
    if (c.part.present) {
      fs << "part" << "{";
      fs << "job" << c.part.job << "x_mm" << c.part.xMm << "y_mm" << c.part.yMm << "z_mm" << c.part.zMm << "rz_deg"
         << c.part.rzDeg;
      fs << "}";
    }
  } catch (const std::exception& e) {  // cv::Exception, and what FileStorage lets through (std::length_error)
    return fail(Status::BadArgument, fmt::format("{}: {}", path, e.what()));
  }
  return {};
}

}  // namespace vgr::vision::calib
