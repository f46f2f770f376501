#include "vision/calib/robot_pose_file.hpp"

#include <cmath>
#include <fstream>
#include <sstream>
#include <stdexcept>

#include <Eigen/Geometry>
#include <fmt/core.h>

#include "vision/calib/se3.hpp"

namespace vgr::vision::calib {
namespace {

using se3::Iso;
constexpr double kDeg = M_PI / 180.0;

}  // namespace

Result<std::vector<PoseEntry>> parsePoseFile(const std::string& text, const std::string& src) {
  enum class Fmt { None, Abb, Fanuc, Ur } format = Fmt::None;
  double scale = 0;  // mm per unit
  std::vector<PoseEntry> out;
  std::istringstream in(text);
  std::string line;
  int lineNo = 0;
  while (std::getline(in, line)) {
    ++lineNo;
    if (auto h = line.find('#'); h != std::string::npos) line.resize(h);
    std::istringstream ls(line);
    std::string first;
    if (!(ls >> first)) continue;
    if (first == "format" || first == "units") {
      std::string val;
      ls >> val;
      if (first == "format") {
        if (val == "abb") format = Fmt::Abb;
        else if (val == "fanuc") format = Fmt::Fanuc;
        else if (val == "ur") format = Fmt::Ur;
        else return fail(Status::BadArgument, fmt::format("{}:{}: format '{}': expected abb, fanuc or ur", src, lineNo, val));
      } else {
        if (val == "mm") scale = 1;
        else if (val == "m") scale = 1000;
        else return fail(Status::BadArgument, fmt::format("{}:{}: units '{}': expected mm or m", src, lineNo, val));
      }
      continue;
    }
    if (format == Fmt::None || scale == 0)
      return fail(Status::BadArgument, fmt::format("{}:{}: pose before the 'format abb|fanuc|ur' and 'units mm|m' lines", src, lineNo));
    std::vector<double> v;
    std::string tok;
    while (ls >> tok) {
      try {
        std::size_t used = 0;
        v.push_back(std::stod(tok, &used));
        if (used != tok.size()) throw std::invalid_argument(tok);
      } catch (const std::exception&) {
        return fail(Status::BadArgument, fmt::format("{}:{}: '{}' is not a number", src, lineNo, tok));
      }
    }
    const std::size_t want = format == Fmt::Abb ? 7 : 6;
    if (v.size() != want)
      return fail(Status::BadArgument, fmt::format("{}:{}: image '{}': {} numbers, expected {} ({})", src, lineNo, first,
                                                   v.size(), want,
                                                   format == Fmt::Abb     ? "x y z qw qx qy qz"
                                                   : format == Fmt::Fanuc ? "x y z w p r"
                                                                          : "x y z rx ry rz"));
    Iso t = Iso::Identity();
    t.translation() = Eigen::Vector3d(v[0], v[1], v[2]) * scale;
    if (format == Fmt::Abb) {
      const Eigen::Quaterniond q(v[3], v[4], v[5], v[6]);
      if (std::abs(q.norm() - 1.0) > 1e-3)
        return fail(Status::BadArgument, fmt::format("{}:{}: quaternion norm {:.6f}, expected 1", src, lineNo, q.norm()));
      t.linear() = q.normalized().toRotationMatrix();
    } else if (format == Fmt::Fanuc) {
      t.linear() = (Eigen::AngleAxisd(v[5] * kDeg, Eigen::Vector3d::UnitZ()) *
                    Eigen::AngleAxisd(v[4] * kDeg, Eigen::Vector3d::UnitY()) *
                    Eigen::AngleAxisd(v[3] * kDeg, Eigen::Vector3d::UnitX()))
                       .toRotationMatrix();
    } else {
      const Eigen::Vector3d rv(v[3], v[4], v[5]);
      t.linear() = rv.norm() < 1e-15 ? Eigen::Matrix3d::Identity()
                                     : Eigen::AngleAxisd(rv.norm(), rv.normalized()).toRotationMatrix();
    }
    out.push_back({first, se3::toPose(t), lineNo});
  }
  if (out.empty()) return fail(Status::BadArgument, fmt::format("{}: no poses", src));
  return out;
}

Result<std::vector<PoseEntry>> loadPoseFile(const std::string& path) {
  std::ifstream f(path);
  if (!f) return fail(Status::BadArgument, fmt::format("{}: cannot open pose file", path));
  std::stringstream ss;
  ss << f.rdbuf();
  return parsePoseFile(ss.str(), path);
}

Result<std::string> poseFileText(const std::string& format, const std::vector<PoseEntry>& poses) {
  if (format != "abb" && format != "fanuc" && format != "ur")
    return fail(Status::BadArgument, fmt::format("pose file format '{}': expected abb, fanuc or ur", format));
  std::string text = "# robot poses T_base_gripper as the controller reports them, one line per image\n";
  text += fmt::format("format {}\nunits {}\n", format, format == "ur" ? "m" : "mm");
  for (const auto& e : poses) {
    const Pose& p = e.baseFromGripper;
    if (format == "abb") {
      text += fmt::format("{} {:.4f} {:.4f} {:.4f} {:.9f} {:.9f} {:.9f} {:.9f}\n", e.image, p.x, p.y, p.z, p.qw, p.qx, p.qy, p.qz);
    } else if (format == "fanuc") {
      const EulerZyxDeg a = toEulerZyxDeg(p);
      text += fmt::format("{} {:.4f} {:.4f} {:.4f} {:.6f} {:.6f} {:.6f}\n", e.image, p.x, p.y, p.z, a.rx, a.ry, a.rz);
    } else {
      const Vec3 rv = toRotationVector(p);
      text += fmt::format("{} {:.7f} {:.7f} {:.7f} {:.9f} {:.9f} {:.9f}\n", e.image, p.x / 1000, p.y / 1000, p.z / 1000,
                          rv.x, rv.y, rv.z);
    }
  }
  return text;
}

Result<void> writePoseFile(const std::string& path, const std::string& format, const std::vector<PoseEntry>& poses) {
  auto text = poseFileText(format, poses);
  if (!text) return std::unexpected(text.error());
  std::ofstream out(path);
  out << *text;
  out.close();
  if (!out) return fail(Status::BadArgument, fmt::format("{}: cannot write the pose file", path));
  return {};
}

}  // namespace vgr::vision::calib
