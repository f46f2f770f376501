#include "vision/calib/handeye_solvers.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <Eigen/Geometry>
#include <fmt/core.h>
#include <opencv2/calib3d.hpp>

#include "vision/calib/levmarq.hpp"

namespace vgr::vision::calib::handeye_detail {
namespace {

constexpr double kDeg = M_PI / 180.0;

cv::Mat toCvR(const Iso& t) {
  cv::Mat r(3, 3, CV_64F);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) r.at<double>(i, j) = t.linear()(i, j);
  return r;
}
cv::Mat toCvT(const Iso& t) {
  return (cv::Mat_<double>(3, 1) << t.translation().x(), t.translation().y(), t.translation().z());
}
Iso fromCv(const cv::Mat& r, const cv::Mat& t) {
  Iso out = Iso::Identity();
  cv::Mat r64, t64;
  r.convertTo(r64, CV_64F);
  t.convertTo(t64, CV_64F);
  for (int i = 0; i < 3; ++i) {
    for (int j = 0; j < 3; ++j) out.linear()(i, j) = r64.at<double>(i, j);
    out.translation()(i) = t64.at<double>(i);
  }
  return out;
}

// A_i' = C_i o A_i: the correction's rotation turns the flange about its own origin (base
// axes) and its translation shifts it -- a robot's repeatability as a controller states it
// (position and orientation error at the flange). Not exp(xi) * A_i, which would turn the
// flange about the base origin and so also move it by the rotation times the robot's reach.
Iso correctedPose(const Iso& c, const Iso& a) {
  Iso out = Iso::Identity();
  out.linear() = c.linear() * a.linear();
  out.translation() = a.translation() + c.translation();
  return out;
}

std::string joinNames(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

}  // namespace

Iso yFromView(HandEyeConfig config, const Iso& a, const Iso& x, const Iso& b) {
  return config == HandEyeConfig::EyeInHand ? Iso(a * x * b) : Iso(a.inverse() * x * b);
}

Iso camFromTarget(HandEyeConfig config, const Iso& a, const Iso& x, const Iso& y) {
  return config == HandEyeConfig::EyeInHand ? Iso(x.inverse() * a.inverse() * y) : Iso(x.inverse() * a * y);
}

Consistency consistency(HandEyeConfig config, const std::vector<Iso>& a, const std::vector<Iso>& b, const Iso& x,
                        const Iso* y) {
  std::vector<Iso> ys;
  for (std::size_t i = 0; i < a.size(); ++i) ys.push_back(yFromView(config, a[i], x, b[i]));
  Consistency c;
  c.y = y ? *y : se3::meanIso(ys);
  double st = 0, sr = 0;
  for (const auto& yi : ys) {
    st += (yi.translation() - c.y.translation()).squaredNorm();
    const double ang = se3::rotationAngleDeg(yi.linear() * c.y.linear().transpose());
    sr += ang * ang;
  }
  const double n = static_cast<double>(std::max<std::size_t>(ys.size(), 1));
  c.transMm = std::sqrt(st / n);
  c.rotDeg = std::sqrt(sr / n);
  return c;
}

Result<void> checkPoseSet(const std::vector<std::string>& names, const std::vector<Iso>& a,
                          const HandEyeOptions& o, std::vector<std::string>& warnings) {
  const std::size_t n = a.size();
  if (static_cast<int>(n) < o.minViews)
    return fail(Status::BadArgument, fmt::format("too few views for hand-eye: {} given, at least {} needed (15 "
                                                 "recommended)",
                                                 n, o.minViews));
  double maxAngle = 0;
  std::vector<Eigen::Vector3d> axes;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const Iso rel = a[i].inverse() * a[j];
      const Eigen::AngleAxisd aa(rel.linear());
      const double ang = aa.angle() / kDeg;
      maxAngle = std::max(maxAngle, ang);
      if (ang > 2.0) axes.push_back(aa.axis());
      if (rel.translation().norm() < o.duplicateMm && ang < o.duplicateDeg)
        warnings.push_back(fmt::format("views '{}' and '{}' have the same robot pose ({:.3f} mm, {:.3f} deg apart): "
                                       "duplicates add no information",
                                       names[i], names[j], rel.translation().norm(), ang));
    }
  if (maxAngle < o.minRotationDeg)
    return fail(Status::BadArgument,
                fmt::format("degenerate motion: the largest rotation between any two of the {} robot poses ({}) is "
                            "{:.2f} deg, at least {:.0f} deg about two different axes is needed",
                            n, joinNames(names), maxAngle, o.minRotationDeg));
  double spread = 0;
  for (std::size_t i = 0; i < axes.size(); ++i)
    for (std::size_t j = i + 1; j < axes.size(); ++j)
      spread = std::max(spread, std::acos(std::min(1.0, std::abs(axes[i].dot(axes[j])))) / kDeg);
  if (spread < o.minAxisSpreadDeg)
    return fail(Status::BadArgument,
                fmt::format("degenerate motion: every rotation between the robot poses ({}) is about the same axis "
                            "(spread {:.2f} deg); rotate about at least two different axes",
                            joinNames(names), spread));
  if (maxAngle > 120)
    warnings.push_back(fmt::format("relative rotations up to {:.0f} deg: Tsai is unreliable above ~120 deg "
                                   "(checked by consistency below)",
                                   maxAngle));
  return {};
}

std::vector<ClosedForm> closedFormSolutions(HandEyeConfig config, const std::vector<Iso>& a, const std::vector<Iso>& b) {
  // OpenCV inputs. calibrateHandEye solves eye-in-hand (gripper2base, target2cam ->
  // cam2gripper); for eye-to-hand the robot poses are inverted (base2gripper) and the
  // output is cam2base.
  std::vector<cv::Mat> rG, tG, rT, tT, rW2C, tW2C, rB2G, tB2G;
  for (std::size_t i = 0; i < a.size(); ++i) {
    const Iso g = config == HandEyeConfig::EyeInHand ? a[i] : a[i].inverse();
    rG.push_back(toCvR(g));
    tG.push_back(toCvT(g));
    rT.push_back(toCvR(b[i]));
    tT.push_back(toCvT(b[i]));
    // Robot-world-hand-eye, A X = Z B with A = cTw, B = gTb: eye-in-hand uses the target as
    // the world; eye-to-hand swaps roles (the target plays the camera, the camera the world).
    const Iso w2c = config == HandEyeConfig::EyeInHand ? b[i] : b[i].inverse();
    rW2C.push_back(toCvR(w2c));
    tW2C.push_back(toCvT(w2c));
    const Iso b2g = a[i].inverse();
    rB2G.push_back(toCvR(b2g));
    tB2G.push_back(toCvT(b2g));
  }
  std::vector<ClosedForm> out;
  auto checked = [&](const char* name, const std::function<Iso()>& solve) {
    ClosedForm c;
    c.method = name;
    Iso x;
    try {
      x = solve();
    } catch (const cv::Exception& e) {
      c.note = fmt::format("OpenCV threw: {}", e.err);
      out.push_back(c);
      return;
    }
    if (!se3::isValidRigid(x) || x.translation().norm() > 1e5) {
      c.note = x.matrix().allFinite() ? "not a rigid transform or translation > 100 m" : "NaN in the result";
      out.push_back(c);
      return;
    }
    c.x = x;
    out.push_back(c);
  };
  const std::pair<const char*, cv::HandEyeCalibrationMethod> heMethods[] = {
      {"tsai", cv::CALIB_HAND_EYE_TSAI},       {"park", cv::CALIB_HAND_EYE_PARK},
      {"horaud", cv::CALIB_HAND_EYE_HORAUD},   {"andreff", cv::CALIB_HAND_EYE_ANDREFF},
      {"daniilidis", cv::CALIB_HAND_EYE_DANIILIDIS}};
  for (const auto& [name, method] : heMethods)
    checked(name, [&, method = method]() {
      cv::Mat r, t;
      cv::calibrateHandEye(rG, tG, rT, tT, r, t, method);
      return fromCv(r, t);
    });
  const std::pair<const char*, cv::RobotWorldHandEyeCalibrationMethod> rwMethods[] = {
      {"rwhe-shah", cv::CALIB_ROBOT_WORLD_HAND_EYE_SHAH}, {"rwhe-li", cv::CALIB_ROBOT_WORLD_HAND_EYE_LI}};
  for (const auto& [name, method] : rwMethods)
    checked(name, [&, method = method]() {
      cv::Mat rb2w, tb2w, rg2c, tg2c;
      cv::calibrateRobotWorldHandEye(rW2C, tW2C, rB2G, tB2G, rb2w, tb2w, rg2c, tg2c, method);
      // eye-in-hand: Z = T_cam_gripper = X^-1; eye-to-hand: X_out = T_cam_base = X^-1.
      return config == HandEyeConfig::EyeInHand ? Iso(fromCv(rg2c, tg2c).inverse()) : Iso(fromCv(rb2w, tb2w).inverse());
    });
  return out;
}

void refineJoint(const std::vector<Iso>& a, std::size_t residualsPerView, const ViewResidualFn& viewResiduals, Iso& x,
                 Iso& y, double sigmaMm, double sigmaRad, std::vector<Iso>* corrected) {
  const std::size_t n = a.size();
  const auto m = static_cast<Eigen::Index>(residualsPerView);
  const Eigen::Index rowsPerView = m + 6;
  const Eigen::Index nr = rowsPerView * static_cast<Eigen::Index>(n), np = 12 + 6 * static_cast<Eigen::Index>(n);
  std::vector<Iso> c(n, Iso::Identity());
  auto viewRes = [&](const Iso& xx, const Iso& yy, const Iso& ci, std::size_t i) {
    Eigen::VectorXd r(rowsPerView);
    viewResiduals(xx, yy, correctedPose(ci, a[i]), i, r.head(m));
    const Eigen::AngleAxisd turn(ci.linear());
    r.segment<3>(m) = ci.translation() / sigmaMm;
    r.segment<3>(m + 3) = turn.axis() * turn.angle() / sigmaRad;
    return r;
  };
  auto allRes = [&](const Iso& xx, const Iso& yy, const std::vector<Iso>& cc) {
    Eigen::VectorXd r(nr);
    for (std::size_t i = 0; i < n; ++i) r.segment(rowsPerView * static_cast<Eigen::Index>(i), rowsPerView) = viewRes(xx, yy, cc[i], i);
    return r;
  };
  auto step = [](const Iso& t, const se3::Vec6& d) { return Iso(se3::expSe3(d) * t); };
  // The corrected robot poses of the solution, however the loop ends.
  struct Report {
    const std::vector<Iso>& a;
    const std::vector<Iso>& c;
    std::vector<Iso>* out;
    ~Report() {
      if (!out) return;
      out->clear();
      for (std::size_t i = 0; i < a.size(); ++i) out->push_back(correctedPose(c[i], a[i]));
    }
  } report{a, c, corrected};
  Eigen::VectorXd r = allRes(x, y, c);
  double cost = r.squaredNorm(), lambda = 1e-3;
  for (int it = 0; it < 30; ++it) {
    Eigen::MatrixXd jac = Eigen::MatrixXd::Zero(nr, np);
    for (int col = 0; col < 12; ++col) {
      const double h = (col % 6) < 3 ? 1e-4 : 1e-6;
      se3::Vec6 d = se3::Vec6::Zero();
      d(col % 6) = h;
      const bool isX = col < 6;
      const Eigen::VectorXd rp = allRes(isX ? step(x, d) : x, isX ? y : step(y, d), c);
      const Eigen::VectorXd rm = allRes(isX ? step(x, -d) : x, isX ? y : step(y, -d), c);
      jac.col(col) = (rp - rm) / (2 * h);
    }
    for (std::size_t i = 0; i < n; ++i)
      for (int k = 0; k < 6; ++k) {
        const double h = k < 3 ? 1e-4 : 1e-6;
        se3::Vec6 d = se3::Vec6::Zero();
        d(k) = h;
        const Eigen::VectorXd rp = viewRes(x, y, step(c[i], d), i), rm = viewRes(x, y, step(c[i], -d), i);
        jac.block(rowsPerView * static_cast<Eigen::Index>(i), 12 + 6 * static_cast<Eigen::Index>(i) + k, rowsPerView, 1) =
            (rp - rm) / (2 * h);
      }
    const Eigen::MatrixXd jtj = jac.transpose() * jac;
    const Eigen::VectorXd g = jac.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      const Eigen::VectorXd dlt = dampedStep(jtj, g, lambda);
      const Iso xc = step(x, dlt.segment<6>(0)), yc = step(y, dlt.segment<6>(6));
      std::vector<Iso> cc(n);
      for (std::size_t i = 0; i < n; ++i) cc[i] = step(c[i], dlt.segment<6>(12 + 6 * static_cast<Eigen::Index>(i)));
      const Eigen::VectorXd rc = allRes(xc, yc, cc);
      const double costC = rc.squaredNorm();
      if (std::isfinite(costC) && costC < cost) {
        const double rel = (cost - costC) / std::max(cost, 1e-30);
        x = xc, y = yc, c = cc, r = rc, cost = costC;
        lambda = std::max(lambda / 10, 1e-12);
        improved = true;
        if (rel < 1e-10) return;
      } else {
        lambda *= 10;
      }
    }
    if (!improved) return;
  }
}

}  // namespace vgr::vision::calib::handeye_detail
