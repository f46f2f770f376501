#include "vision/calib/handeye.hpp"

#include <algorithm>
#include <cmath>
#include <functional>

#include <Eigen/Dense>
#include <fmt/core.h>
#include <opencv2/calib3d.hpp>

#include "vision/calib/handeye_solvers.hpp"
#include "vision/calib/levmarq.hpp"
#include "vision/calib/se3.hpp"

namespace vgr::vision::calib {
namespace {

using se3::Iso;
namespace hd = handeye_detail;
constexpr double kDeg = M_PI / 180.0;

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

  // T_cam_target_i predicted by the chain A_i, X, Y.
  Iso camFromTarget(const Iso& x, const Iso& y, std::size_t i) const { return hd::camFromTarget(config, a[i], x, y); }
};

void evaluate(const Problem& p, HandEyeMethodResult& m, const Iso& x, const Iso* yGiven) {
  const hd::Consistency c = hd::consistency(p.config, p.a, p.b, x, yGiven);
  m.transResidMm = c.transMm;
  m.rotResidDeg = c.rotDeg;
  double se = 0;
  std::size_t cnt = 0;
  for (std::size_t i = 0; i < p.a.size(); ++i) {
    cv::Vec3d rv, tv;
    se3::toRvecTvec(p.camFromTarget(x, c.y, i), rv, tv);
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
  m.y = se3::toPose(c.y);
}

// The joint refinement (handeye_solvers.hpp) with the reprojection of every pattern point
// through A_i', X, Y as the measurement, / sigmaPx.
void refineJoint(const Problem& p, Iso& x, Iso& y, double sigmaPx, double sigmaMm, double sigmaRad) {
  const std::size_t m = p.obj.size();
  hd::refineJoint(
      p.a, 2 * m,
      [&](const Iso& xx, const Iso& yy, const Iso& a, std::size_t i, Eigen::Ref<Eigen::VectorXd> out) {
        cv::Vec3d rv, tv;
        se3::toRvecTvec(hd::camFromTarget(p.config, a, xx, yy), rv, tv);
        std::vector<cv::Point2f> proj;
        cv::projectPoints(p.obj, rv, tv, p.k, p.d, proj);
        for (std::size_t j = 0; j < m; ++j) {
          out(static_cast<Eigen::Index>(2 * j)) = (proj[j].x - p.img[i][j].x) / sigmaPx;
          out(static_cast<Eigen::Index>(2 * j + 1)) = (proj[j].y - p.img[i][j].y) / sigmaPx;
        }
      },
      x, y, sigmaMm, sigmaRad);
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
  if (auto ok = hd::checkPoseSet(p.names, p.a, options, res.warnings); !ok) return std::unexpected(ok.error());

  for (const auto& c : hd::closedFormSolutions(config, p.a, p.b)) {
    HandEyeMethodResult m;
    m.method = c.method;
    m.note = c.note;
    if (c.x) {
      evaluate(p, m, *c.x, nullptr);
      m.valid = m.rotResidDeg <= options.maxRotResidDeg && m.transResidMm <= options.maxTransResidMm;
      if (!m.valid)
        m.note = fmt::format("inconsistent: views disagree by {:.2f} mm / {:.3f} deg RMS", m.transResidMm, m.rotResidDeg);
    }
    res.methods.push_back(m);
  }

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
