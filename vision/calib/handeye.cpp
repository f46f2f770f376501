#include "vision/calib/handeye.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Dense>
#include <fmt/core.h>
#include <opencv2/calib3d.hpp>

#include "vision/calib/levmarq.hpp"
#include "vision/calib/se3.hpp"

namespace vgr::vision::calib {
namespace {

using se3::Iso;
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

// The data every method and the refinement work on.
struct Problem {
  HandEyeConfig config;
  std::vector<std::string> names;
  std::vector<Iso> a;  // T_base_gripper_i
  std::vector<Iso> b;  // T_cam_target_i (solvePnP)
  std::vector<std::vector<cv::Point2f>> img;
  std::vector<cv::Point3f> obj;
  cv::Matx33d k;
  cv::Vec<double, 5> d;

  // Y seen through view i for a given X (should be the same for every view).
  Iso yFromView(const Iso& x, std::size_t i) const {
    return config == HandEyeConfig::EyeInHand ? Iso(a[i] * x * b[i]) : Iso(a[i].inverse() * x * b[i]);
  }
  // T_cam_target_i predicted by the chain A_i, X, Y.
  Iso camFromTarget(const Iso& x, const Iso& y, std::size_t i) const {
    return config == HandEyeConfig::EyeInHand ? Iso(x.inverse() * a[i].inverse() * y) : Iso(x.inverse() * a[i] * y);
  }
};

void evaluate(const Problem& p, HandEyeMethodResult& m, const Iso& x, const Iso* yGiven) {
  std::vector<Iso> ys;
  for (std::size_t i = 0; i < p.a.size(); ++i) ys.push_back(p.yFromView(x, i));
  const Iso y = yGiven ? *yGiven : se3::meanIso(ys);
  double st = 0, sr = 0;
  for (const auto& yi : ys) {
    st += (yi.translation() - y.translation()).squaredNorm();
    const double ang = se3::rotationAngleDeg(yi.linear() * y.linear().transpose());
    sr += ang * ang;
  }
  const double n = static_cast<double>(ys.size());
  m.transResidMm = std::sqrt(st / n);
  m.rotResidDeg = std::sqrt(sr / n);
  double se = 0;
  std::size_t cnt = 0;
  for (std::size_t i = 0; i < p.a.size(); ++i) {
    cv::Vec3d rv, tv;
    se3::toRvecTvec(p.camFromTarget(x, y, i), rv, tv);
    std::vector<cv::Point2f> proj;
    cv::projectPoints(p.obj, rv, tv, p.k, p.d, proj);
    for (std::size_t j = 0; j < proj.size(); ++j) {
      const cv::Point2f e = proj[j] - p.img[i][j];
      se += e.x * e.x + e.y * e.y;
      ++cnt;
    }
  }
  m.reprojRmsPx = std::sqrt(se / std::max<std::size_t>(cnt, 1));
  m.x = se3::toPose(x);
  m.y = se3::toPose(y);
}

// Joint maximum-likelihood refinement of X, Y and a small correction C_i per robot pose
// (A_i' = C_i A_i, C_i = exp(xi_i), paper 003 eqs. 4-8 for the parametrisation). Residuals:
// reprojection / sigmaPx for every pattern point, and xi_i / (sigmaMm, sigmaRad) as the prior
// that the controller's pose is right within its repeatability. The same hand-written LM as
// levmarq.hpp, with the Jacobian's block structure used: C_i only moves view i's residuals.
void refineJoint(const Problem& p, Iso& x, Iso& y, double sigmaPx, double sigmaMm, double sigmaRad) {
  const std::size_t n = p.a.size(), m = p.obj.size();
  const Eigen::Index rowsPerView = static_cast<Eigen::Index>(2 * m + 6);
  const Eigen::Index nr = rowsPerView * static_cast<Eigen::Index>(n), np = 12 + 6 * static_cast<Eigen::Index>(n);
  std::vector<Iso> c(n, Iso::Identity());
  auto viewRes = [&](const Iso& xx, const Iso& yy, const Iso& ci, std::size_t i) {
    Eigen::VectorXd r(rowsPerView);
    const Iso a = ci * p.a[i];
    const Iso ct = p.config == HandEyeConfig::EyeInHand ? Iso(xx.inverse() * a.inverse() * yy) : Iso(xx.inverse() * a * yy);
    cv::Vec3d rv, tv;
    se3::toRvecTvec(ct, rv, tv);
    std::vector<cv::Point2f> proj;
    cv::projectPoints(p.obj, rv, tv, p.k, p.d, proj);
    for (std::size_t j = 0; j < m; ++j) {
      r(static_cast<Eigen::Index>(2 * j)) = (proj[j].x - p.img[i][j].x) / sigmaPx;
      r(static_cast<Eigen::Index>(2 * j + 1)) = (proj[j].y - p.img[i][j].y) / sigmaPx;
    }
    const se3::Vec6 xi = se3::logSe3(ci);
    r.segment<3>(static_cast<Eigen::Index>(2 * m)) = xi.head<3>() / sigmaMm;
    r.segment<3>(static_cast<Eigen::Index>(2 * m + 3)) = xi.tail<3>() / sigmaRad;
    return r;
  };
  auto allRes = [&](const Iso& xx, const Iso& yy, const std::vector<Iso>& cc) {
    Eigen::VectorXd r(nr);
    for (std::size_t i = 0; i < n; ++i) r.segment(rowsPerView * static_cast<Eigen::Index>(i), rowsPerView) = viewRes(xx, yy, cc[i], i);
    return r;
  };
  auto step = [](const Iso& t, const se3::Vec6& d) { return Iso(se3::expSe3(d) * t); };
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

std::string joinNames(const std::vector<std::string>& v) {
  std::string s;
  for (const auto& x : v) s += (s.empty() ? "" : ", ") + x;
  return s;
}

Result<void> checkMotion(const Problem& p, const HandEyeOptions& o, std::vector<std::string>& warnings) {
  const std::size_t n = p.a.size();
  double maxAngle = 0;
  std::vector<Eigen::Vector3d> axes;
  for (std::size_t i = 0; i < n; ++i)
    for (std::size_t j = i + 1; j < n; ++j) {
      const Iso rel = p.a[i].inverse() * p.a[j];
      const Eigen::AngleAxisd aa(rel.linear());
      const double ang = aa.angle() / kDeg;
      maxAngle = std::max(maxAngle, ang);
      if (ang > 2.0) axes.push_back(aa.axis());
      if (rel.translation().norm() < o.duplicateMm && ang < o.duplicateDeg)
        warnings.push_back(fmt::format("views '{}' and '{}' have the same robot pose ({:.3f} mm, {:.3f} deg apart): "
                                       "duplicates add no information",
                                       p.names[i], p.names[j], rel.translation().norm(), ang));
    }
  if (maxAngle < o.minRotationDeg)
    return fail(Status::BadArgument,
                fmt::format("degenerate motion: the largest rotation between any two of the {} robot poses ({}) is "
                            "{:.2f} deg, at least {:.0f} deg about two different axes is needed",
                            n, joinNames(p.names), maxAngle, o.minRotationDeg));
  double spread = 0;
  for (std::size_t i = 0; i < axes.size(); ++i)
    for (std::size_t j = i + 1; j < axes.size(); ++j)
      spread = std::max(spread, std::acos(std::min(1.0, std::abs(axes[i].dot(axes[j])))) / kDeg);
  if (spread < o.minAxisSpreadDeg)
    return fail(Status::BadArgument,
                fmt::format("degenerate motion: every rotation between the robot poses ({}) is about the same axis "
                            "(spread {:.2f} deg); rotate about at least two different axes",
                            joinNames(p.names), spread));
  if (maxAngle > 120)
    warnings.push_back(fmt::format("relative rotations up to {:.0f} deg: Tsai is unreliable above ~120 deg "
                                   "(checked by consistency below)",
                                   maxAngle));
  return {};
}

}  // namespace

const char* handEyeConfigName(HandEyeConfig c) { return c == HandEyeConfig::EyeInHand ? "eye-in-hand" : "eye-to-hand"; }

Result<HandEyeResult> calibrateHandEye(const std::vector<HandEyeView>& views, const CameraIntrinsics& cam,
                                       const PatternSpec& pattern, HandEyeConfig config,
                                       const HandEyeOptions& options) {
  Problem p;
  p.config = config;
  p.obj = patternObjectPoints(pattern);
  p.k = cam.cameraMatrix;
  p.d = cam.dist;
  if (static_cast<int>(views.size()) < options.minViews)
    return fail(Status::BadArgument, fmt::format("too few views for hand-eye: {} given, at least {} needed (15 "
                                                 "recommended)",
                                                 views.size(), options.minViews));
  HandEyeResult res;
  res.config = config;
  for (const auto& v : views) {
    if (v.corners.size() != p.obj.size())
      return fail(Status::BadArgument, fmt::format("view '{}': {} pattern points, the {}x{} {} has {}", v.name,
                                                   v.corners.size(), pattern.cols, pattern.rows,
                                                   patternKindName(pattern.kind), p.obj.size()));
    cv::Vec3d rv, tv;
    if (!cv::solvePnP(p.obj, v.corners, p.k, p.d, rv, tv, false, cv::SOLVEPNP_ITERATIVE))
      return fail(Status::BadArgument, fmt::format("view '{}': solvePnP failed", v.name));
    p.names.push_back(v.name);
    p.a.push_back(se3::toIso(v.baseFromGripper));
    p.b.push_back(se3::fromRvecTvec(rv, tv));
    p.img.push_back(v.corners);
  }
  if (auto ok = checkMotion(p, options, res.warnings); !ok) return std::unexpected(ok.error());

  // OpenCV inputs. calibrateHandEye solves eye-in-hand (gripper2base, target2cam ->
  // cam2gripper); for eye-to-hand the robot poses are inverted (base2gripper) and the
  // output is cam2base.
  std::vector<cv::Mat> rG, tG, rT, tT, rW2C, tW2C, rB2G, tB2G;
  for (std::size_t i = 0; i < p.a.size(); ++i) {
    const Iso g = config == HandEyeConfig::EyeInHand ? p.a[i] : p.a[i].inverse();
    rG.push_back(toCvR(g));
    tG.push_back(toCvT(g));
    rT.push_back(toCvR(p.b[i]));
    tT.push_back(toCvT(p.b[i]));
    // Robot-world-hand-eye, A X = Z B with A = cTw, B = gTb: eye-in-hand uses the plate as
    // the world; eye-to-hand swaps roles (the plate plays the camera, the camera the world).
    const Iso w2c = config == HandEyeConfig::EyeInHand ? p.b[i] : p.b[i].inverse();
    rW2C.push_back(toCvR(w2c));
    tW2C.push_back(toCvT(w2c));
    const Iso b2g = p.a[i].inverse();
    rB2G.push_back(toCvR(b2g));
    tB2G.push_back(toCvT(b2g));
  }
  const std::pair<const char*, cv::HandEyeCalibrationMethod> heMethods[] = {
      {"tsai", cv::CALIB_HAND_EYE_TSAI},       {"park", cv::CALIB_HAND_EYE_PARK},
      {"horaud", cv::CALIB_HAND_EYE_HORAUD},   {"andreff", cv::CALIB_HAND_EYE_ANDREFF},
      {"daniilidis", cv::CALIB_HAND_EYE_DANIILIDIS}};
  auto addChecked = [&](const char* name, const std::function<Iso()>& solve) {
    HandEyeMethodResult m;
    m.method = name;
    Iso x;
    try {
      x = solve();
    } catch (const cv::Exception& e) {
      m.note = fmt::format("OpenCV threw: {}", e.err);
      res.methods.push_back(m);
      return;
    }
    if (!se3::isValidRigid(x) || x.translation().norm() > 1e5) {
      m.note = x.matrix().allFinite() ? "not a rigid transform or translation > 100 m" : "NaN in the result";
      res.methods.push_back(m);
      return;
    }
    evaluate(p, m, x, nullptr);
    m.valid = m.rotResidDeg <= options.maxRotResidDeg && m.transResidMm <= options.maxTransResidMm;
    if (!m.valid)
      m.note = fmt::format("inconsistent: views disagree by {:.2f} mm / {:.3f} deg RMS", m.transResidMm, m.rotResidDeg);
    res.methods.push_back(m);
  };
  for (const auto& [name, method] : heMethods)
    addChecked(name, [&, method = method]() {
      cv::Mat r, t;
      cv::calibrateHandEye(rG, tG, rT, tT, r, t, method);
      return fromCv(r, t);
    });
  const std::pair<const char*, cv::RobotWorldHandEyeCalibrationMethod> rwMethods[] = {
      {"rwhe-shah", cv::CALIB_ROBOT_WORLD_HAND_EYE_SHAH}, {"rwhe-li", cv::CALIB_ROBOT_WORLD_HAND_EYE_LI}};
  for (const auto& [name, method] : rwMethods)
    addChecked(name, [&, method = method]() {
      cv::Mat rb2w, tb2w, rg2c, tg2c;
      cv::calibrateRobotWorldHandEye(rW2C, tW2C, rB2G, tB2G, rb2w, tb2w, rg2c, tg2c, method);
      // eye-in-hand: Z = T_cam_gripper = X^-1; eye-to-hand: X_out = T_cam_base = X^-1.
      return config == HandEyeConfig::EyeInHand ? Iso(fromCv(rg2c, tg2c).inverse()) : Iso(fromCv(rb2w, tb2w).inverse());
    });

  int seed = -1;
  for (std::size_t i = 0; i < res.methods.size(); ++i)
    if (res.methods[i].valid && (seed < 0 || res.methods[i].reprojRmsPx < res.methods[static_cast<std::size_t>(seed)].reprojRmsPx))
      seed = static_cast<int>(i);
  if (seed < 0) {
    std::string why;
    for (const auto& m : res.methods) why += fmt::format("; {}: {}", m.method, m.note);
    return fail(Status::BadArgument, fmt::format("hand-eye ({}): no method gave a consistent result (wrong "
                                                 "configuration, or robot poses not matching the images?){}",
                                                 handEyeConfigName(config), why));
  }

  // Nonlinear refinement of X and Y together: reprojection error of every pattern point
  // through A_i, X, Y (robot poses taken as exact).
  {
    const auto& s = res.methods[static_cast<std::size_t>(seed)];
    std::vector<Iso> xy = {se3::toIso(s.x), se3::toIso(s.y)};
    const std::size_t npts = p.obj.size() * p.a.size();
    auto reproj = [&](const std::vector<Iso>& q) {
      Eigen::VectorXd r(static_cast<Eigen::Index>(2 * npts));
      Eigen::Index k = 0;
      for (std::size_t i = 0; i < p.a.size(); ++i) {
        cv::Vec3d rv, tv;
        se3::toRvecTvec(p.camFromTarget(q[0], q[1], i), rv, tv);
        std::vector<cv::Point2f> proj;
        cv::projectPoints(p.obj, rv, tv, p.k, p.d, proj);
        for (std::size_t j = 0; j < proj.size(); ++j) {
          r(k++) = proj[j].x - p.img[i][j].x;
          r(k++) = proj[j].y - p.img[i][j].y;
        }
      }
      return r;
    };
    levenbergMarquardt(xy, reproj);
    HandEyeMethodResult m;
    m.method = "refined-reproj";
    evaluate(p, m, xy[0], &xy[1]);
    m.valid = se3::isValidRigid(xy[0]) && m.rotResidDeg <= options.maxRotResidDeg &&
              m.transResidMm <= options.maxTransResidMm;
    m.note = fmt::format("LM on SE(3) x SE(3) from {}, robot poses exact", s.method);
    res.methods.push_back(m);
    // Joint refinement: the robot poses are measurements too (maximum likelihood under the
    // stated noise). Pixel sigma: options.cornerSigmaPx, else estimated from the fit above.
    const double sigmaPx = options.cornerSigmaPx > 0 ? options.cornerSigmaPx
                                                     : std::max(m.reprojRmsPx / std::sqrt(2.0), 0.01);
    Iso xj = xy[0], yj = xy[1];
    refineJoint(p, xj, yj, sigmaPx, options.robotSigmaMm, options.robotSigmaDeg * kDeg);
    HandEyeMethodResult mj;
    mj.method = "refined";
    evaluate(p, mj, xj, &yj);
    mj.valid = se3::isValidRigid(xj) && mj.rotResidDeg <= options.maxRotResidDeg &&
               mj.transResidMm <= options.maxTransResidMm;
    mj.note = fmt::format("LM over X, Y and a correction per robot pose (robot sigma {} mm / {} deg, corner sigma "
                          "{:.3f} px), from {}",
                          options.robotSigmaMm, options.robotSigmaDeg, sigmaPx, s.method);
    res.methods.push_back(mj);
  }
  // Paper 003 (eqs. 1-3, 9): register every view's corner cloud onto view 1's through X.
  {
    const auto& s = res.methods[static_cast<std::size_t>(seed)];
    std::vector<Iso> xs = {se3::toIso(s.x)};
    std::vector<std::vector<Eigen::Vector3d>> clouds(p.a.size());
    for (std::size_t i = 0; i < p.a.size(); ++i)
      for (const auto& o : p.obj) clouds[i].push_back(p.b[i] * Eigen::Vector3d(o.x, o.y, o.z));
    auto reg = [&](const std::vector<Iso>& q) {
      const Iso& x = q[0];
      Eigen::VectorXd r(static_cast<Eigen::Index>(3 * p.obj.size() * (p.a.size() - 1)));
      Eigen::Index k = 0;
      for (std::size_t i = 1; i < p.a.size(); ++i) {
        // eye-to-hand (paper eq. 2): X^-1 A_1 A_i^-1 X; eye-in-hand: X^-1 A_1^-1 A_i X.
        const Iso m = p.config == HandEyeConfig::EyeToHand ? Iso(x.inverse() * p.a[0] * p.a[i].inverse() * x)
                                                           : Iso(x.inverse() * p.a[0].inverse() * p.a[i] * x);
        for (std::size_t j = 0; j < p.obj.size(); ++j) {
          r.segment<3>(k) = m * clouds[i][j] - clouds[0][j];
          k += 3;
        }
      }
      return r;
    };
    levenbergMarquardt(xs, reg);
    HandEyeMethodResult m;
    m.method = "registration";
    evaluate(p, m, xs[0], nullptr);
    m.valid = se3::isValidRigid(xs[0]) && m.rotResidDeg <= options.maxRotResidDeg &&
              m.transResidMm <= options.maxTransResidMm;
    m.note = fmt::format("paper 003 point registration in se(3) from {}", s.method);
    res.methods.push_back(m);
  }

  // The joint refinement is the maximum-likelihood estimate under the noise model, so it is
  // chosen when it is consistent; otherwise the consistent method with the lowest
  // reprojection error.
  std::string why;
  for (std::size_t i = 0; i < res.methods.size(); ++i)
    if (res.methods[i].valid && res.methods[i].method == "refined") res.best = static_cast<int>(i);
  if (res.best >= 0) {
    why = "maximum likelihood over X, Y and the robot poses (a closed-form method's X reprojects at " +
          fmt::format("{:.3f} px", res.methods[static_cast<std::size_t>(seed)].reprojRmsPx) + ")";
  } else {
    for (std::size_t i = 0; i < res.methods.size(); ++i)
      if (res.methods[i].valid && (res.best < 0 || res.methods[i].reprojRmsPx <
                                                       res.methods[static_cast<std::size_t>(res.best)].reprojRmsPx))
        res.best = static_cast<int>(i);
    why = "lowest reprojection error of the consistent methods (the joint refinement was not consistent)";
  }
  const auto& b = res.bestResult();
  std::string rejected;
  for (const auto& m : res.methods)
    if (!m.valid) rejected += fmt::format("{}{} ({})", rejected.empty() ? "" : ", ", m.method, m.note);
  res.reason = fmt::format("{}: {}; reprojection {:.3f} px, views agree on Y within {:.3f} mm / {:.4f} deg RMS{}{}",
                           b.method, why, b.reprojRmsPx, b.transResidMm, b.rotResidDeg,
                           rejected.empty() ? "" : "; rejected: ", rejected);
  return res;
}

Result<HandEyeResult> calibrateHandEyeAuto(const std::vector<HandEyeView>& views, const CameraIntrinsics& cam,
                                           const PatternSpec& pattern, const HandEyeOptions& options) {
  auto ih = calibrateHandEye(views, cam, pattern, HandEyeConfig::EyeInHand, options);
  auto th = calibrateHandEye(views, cam, pattern, HandEyeConfig::EyeToHand, options);
  if (!ih && !th)
    return fail(Status::BadArgument, fmt::format("neither configuration fits: eye-in-hand: {} | eye-to-hand: {}",
                                                 ih.error().message, th.error().message));
  const bool pickIh = ih && (!th || ih->bestResult().reprojRmsPx <= th->bestResult().reprojRmsPx);
  HandEyeResult r = pickIh ? *ih : *th;
  const auto& other = pickIh ? th : ih;
  r.warnings.push_back(other ? fmt::format("configuration chosen by consistency: the other one's best method "
                                           "reprojects at {:.3f} px vs {:.3f} px",
                                           other->bestResult().reprojRmsPx, r.bestResult().reprojRmsPx)
                             : fmt::format("configuration chosen by consistency: the other one failed: {}",
                                           other.error().message));
  return r;
}

}  // namespace vgr::vision::calib
