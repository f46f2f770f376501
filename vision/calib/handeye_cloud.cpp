#include "vision/calib/handeye_cloud.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>
#include <fmt/core.h>

#include "vision/calib/handeye_solvers.hpp"
#include "vision/calib/levmarq.hpp"
#include "vision/calib/se3.hpp"

namespace vgr::vision::calib {
namespace {

using se3::Iso;
using Eigen::Vector3d;
namespace hd = handeye_detail;
constexpr double kDeg = M_PI / 180.0;

Vector3d ev(const Vec3& v) { return {v.x, v.y, v.z}; }

struct CloudProblem {
  HandEyeConfig config;
  std::vector<std::string> names;
  std::vector<Iso> a;                         // T_base_gripper_i
  std::vector<Iso> b;                         // T_cam_target_i (rigid fit)
  std::vector<std::vector<int>> ids;          // per view
  std::vector<std::vector<Vector3d>> points;  // per view, camera frame
  std::vector<Vector3d> model;                // target frame
  std::size_t totalPoints = 0;
};

// RMS distance of the measured points to the target through A_i, X, Y.
double pointRms(const CloudProblem& p, const Iso& x, const Iso& y) {
  double s = 0;
  for (std::size_t i = 0; i < p.a.size(); ++i) {
    const Iso ct = hd::camFromTarget(p.config, p.a[i], x, y);
    for (std::size_t j = 0; j < p.ids[i].size(); ++j)
      s += (ct * p.model[static_cast<std::size_t>(p.ids[i][j])] - p.points[i][j]).squaredNorm();
  }
  return std::sqrt(s / static_cast<double>(std::max<std::size_t>(p.totalPoints, 1)));
}

void evaluate(const CloudProblem& p, HandEyeMethodResult& m, const Iso& x, const Iso* yGiven, const HandEyeOptions& o) {
  const hd::Consistency c = hd::consistency(p.config, p.a, p.b, x, yGiven);
  m.transResidMm = c.transMm;
  m.rotResidDeg = c.rotDeg;
  m.pointRmsMm = pointRms(p, x, c.y);
  m.x = se3::toPose(x);
  m.y = se3::toPose(c.y);
  m.valid = se3::isValidRigid(x) && m.rotResidDeg <= o.maxRotResidDeg && m.transResidMm <= o.maxTransResidMm;
  if (!m.valid && m.note.empty())
    m.note = fmt::format("inconsistent: views disagree by {:.2f} mm / {:.3f} deg RMS", m.transResidMm, m.rotResidDeg);
}

}  // namespace

Result<HandEyeResult> calibrateHandEyeCloud(const std::vector<CloudHandEyeView>& views, const SphereTarget& target,
                                            HandEyeConfig config, const HandEyeOptions& options) {
  if (auto ok = validateSphereTarget(target); !ok) return std::unexpected(ok.error());
  CloudProblem p;
  p.config = config;
  for (const auto& c : target.centres) p.model.push_back(ev(c));
  HandEyeResult res;
  res.config = config;
  for (const auto& v : views) {
    if (v.ids.size() != v.points.size() || v.points.size() < 4)
      return fail(Status::BadArgument, fmt::format("view '{}': {} target points, at least 4 (with their ids) are needed",
                                                   v.name, v.points.size()));
    std::vector<Vec3> from;
    for (int id : v.ids) {
      if (id < 0 || static_cast<std::size_t>(id) >= target.centres.size())
        return fail(Status::BadArgument, fmt::format("view '{}': point id {} is not a sphere of the target", v.name, id));
      from.push_back(target.centres[static_cast<std::size_t>(id)]);
    }
    p.names.push_back(v.name);
    p.a.push_back(se3::toIso(v.baseFromGripper));
    p.b.push_back(se3::toIso(rigidFit(from, v.points)));
    p.ids.push_back(v.ids);
    std::vector<Vector3d> pts;
    for (const auto& q : v.points) pts.push_back(ev(q));
    p.points.push_back(std::move(pts));
    p.totalPoints += v.points.size();
  }
  if (auto ok = hd::checkPoseSet(p.names, p.a, options, res.warnings); !ok) return std::unexpected(ok.error());

  // 1. The closed forms on the rigid fits.
  for (const auto& c : hd::closedFormSolutions(config, p.a, p.b)) {
    HandEyeMethodResult m;
    m.method = c.method;
    m.note = c.note;
    if (c.x) evaluate(p, m, *c.x, nullptr, options);
    res.methods.push_back(m);
  }
  int seed = -1;
  for (std::size_t i = 0; i < res.methods.size(); ++i)
    if (res.methods[i].valid && (seed < 0 || res.methods[i].pointRmsMm < res.methods[static_cast<std::size_t>(seed)].pointRmsMm))
      seed = static_cast<int>(i);
  if (seed < 0) {
    std::string why;
    for (const auto& m : res.methods) why += fmt::format("; {}: {}", m.method, m.note);
    return fail(Status::BadArgument, fmt::format("hand-eye ({}): no method gave a consistent result (wrong "
                                                 "configuration, or robot poses not matching the views?){}",
                                                 handEyeConfigName(config), why));
  }
  const HandEyeMethodResult seedResult = res.methods[static_cast<std::size_t>(seed)];

  // 2. Paper 003 (eqs. 1-3, 9): X alone, each view's cloud onto view 1's through X.
  {
    std::vector<Iso> xs = {se3::toIso(seedResult.x)};
    // Points of view i that view 1 saw too (paper: the same corner j in both clouds).
    std::vector<std::vector<std::pair<std::size_t, std::size_t>>> pairs(p.a.size());
    std::size_t nres = 0;
    for (std::size_t i = 1; i < p.a.size(); ++i)
      for (std::size_t j = 0; j < p.ids[i].size(); ++j)
        for (std::size_t k = 0; k < p.ids[0].size(); ++k)
          if (p.ids[i][j] == p.ids[0][k]) {
            pairs[i].emplace_back(j, k);
            ++nres;
          }
    auto reg = [&](const std::vector<Iso>& q) {
      const Iso& x = q[0];
      Eigen::VectorXd r(static_cast<Eigen::Index>(3 * nres));
      Eigen::Index k = 0;
      for (std::size_t i = 1; i < p.a.size(); ++i) {
        // eq. (2): eye-to-hand X^-1 A_1 A_i^-1 X; eye-in-hand X^-1 A_1^-1 A_i X.
        const Iso m = p.config == HandEyeConfig::EyeToHand ? Iso(x.inverse() * p.a[0] * p.a[i].inverse() * x)
                                                           : Iso(x.inverse() * p.a[0].inverse() * p.a[i] * x);
        for (const auto& [j, k1] : pairs[i]) {
          r.segment<3>(k) = m * p.points[i][j] - p.points[0][k1];
          k += 3;
        }
      }
      return r;
    };
    HandEyeMethodResult m;
    m.method = "registration";
    if (nres >= 6) {
      levenbergMarquardt(xs, reg);
      m.note = fmt::format("paper 003 cloud registration onto view 1 in se(3), from {}", seedResult.method);
      evaluate(p, m, xs[0], nullptr, options);
    } else {
      m.note = "view 1 shares too few points with the others";
    }
    res.methods.push_back(m);
  }

  // 3. X and Y against the target model, robot exact; 4. with the robot's noise.
  {
    std::vector<Iso> xy = {se3::toIso(seedResult.x), se3::toIso(seedResult.y)};
    auto model = [&](const std::vector<Iso>& q) {
      Eigen::VectorXd r(static_cast<Eigen::Index>(3 * p.totalPoints));
      Eigen::Index k = 0;
      for (std::size_t i = 0; i < p.a.size(); ++i) {
        const Iso ct = hd::camFromTarget(p.config, p.a[i], q[0], q[1]);
        for (std::size_t j = 0; j < p.ids[i].size(); ++j) {
          r.segment<3>(k) = ct * p.model[static_cast<std::size_t>(p.ids[i][j])] - p.points[i][j];
          k += 3;
        }
      }
      return r;
    };
    levenbergMarquardt(xy, model);
    HandEyeMethodResult m;
    m.method = "refined-points";
    m.note = fmt::format("LM on SE(3) x SE(3) over every target point, robot poses exact, from {}", seedResult.method);
    evaluate(p, m, xy[0], &xy[1], options);
    res.methods.push_back(m);

    // Point sigma per coordinate: estimated from the fit with the robot exact, then again
    // from the joint fit's own residuals (with the corrected robot poses) until it settles:
    // the robot's noise inflates the first estimate, and a sigma too large would make the
    // joint fit trust the robot more than it should.
    std::size_t maxPoints = 0;
    for (const auto& ids : p.ids) maxPoints = std::max(maxPoints, ids.size());
    double sigmaMm = std::max(m.pointRmsMm / std::sqrt(3.0), 0.005);
    Iso xj = xy[0], yj = xy[1];
    double usedSigmaMm = sigmaMm;
    for (int round = 0; round < 3; ++round) {
      xj = xy[0], yj = xy[1];
      usedSigmaMm = sigmaMm;
      std::vector<Iso> aj;
      // Views with fewer points pad with zeros (their unused residuals stay 0).
      hd::refineJoint(
          p.a, 3 * maxPoints,
          [&](const Iso& x, const Iso& y, const Iso& a, std::size_t i, Eigen::Ref<Eigen::VectorXd> out) {
            out.setZero();
            const Iso ct = hd::camFromTarget(p.config, a, x, y);
            for (std::size_t j = 0; j < p.ids[i].size(); ++j)
              out.segment<3>(static_cast<Eigen::Index>(3 * j)) =
                  (ct * p.model[static_cast<std::size_t>(p.ids[i][j])] - p.points[i][j]) / sigmaMm;
          },
          xj, yj, options.robotSigmaMm, options.robotSigmaDeg * kDeg, &aj);
      CloudProblem corrected = p;
      corrected.a = aj;
      const double next = std::max(pointRms(corrected, xj, yj) / std::sqrt(3.0), 0.005);
      const bool settled = std::abs(next - sigmaMm) < 0.1 * sigmaMm;
      sigmaMm = next;
      if (settled) break;
    }
    HandEyeMethodResult mj;
    mj.method = "refined";
    mj.note = fmt::format("LM over X, Y and a correction per robot pose (robot sigma {} mm / {} deg, point sigma {:.3f} mm), "
                          "from {}",
                          options.robotSigmaMm, options.robotSigmaDeg, usedSigmaMm, seedResult.method);
    evaluate(p, mj, xj, &yj, options);
    res.methods.push_back(mj);
  }

  std::string why;
  for (std::size_t i = 0; i < res.methods.size(); ++i)
    if (res.methods[i].valid && res.methods[i].method == "refined") res.best = static_cast<int>(i);
  if (res.best >= 0) {
    why = fmt::format("maximum likelihood over X, Y and the robot poses (the best closed form, {}, fits at {:.3f} mm)",
                      seedResult.method, seedResult.pointRmsMm);
  } else {
    for (std::size_t i = 0; i < res.methods.size(); ++i)
      if (res.methods[i].valid &&
          (res.best < 0 || res.methods[i].pointRmsMm < res.methods[static_cast<std::size_t>(res.best)].pointRmsMm))
        res.best = static_cast<int>(i);
    why = "lowest point RMS of the consistent methods (the joint refinement was not consistent)";
  }
  const auto& b = res.bestResult();
  std::string rejected;
  for (const auto& m : res.methods)
    if (!m.valid) rejected += fmt::format("{}{} ({})", rejected.empty() ? "" : ", ", m.method, m.note);
  res.reason = fmt::format("{}: {}; target points fit at {:.3f} mm RMS, views agree on Y within {:.3f} mm / {:.4f} deg RMS{}{}",
                           b.method, why, b.pointRmsMm, b.transResidMm, b.rotResidDeg, rejected.empty() ? "" : "; rejected: ",
                           rejected);
  return res;
}

Result<HandEyeResult> calibrateHandEyeCloudAuto(const std::vector<CloudHandEyeView>& views, const SphereTarget& target,
                                                const HandEyeOptions& options) {
  auto ih = calibrateHandEyeCloud(views, target, HandEyeConfig::EyeInHand, options);
  auto th = calibrateHandEyeCloud(views, target, HandEyeConfig::EyeToHand, options);
  if (!ih && !th)
    return fail(Status::BadArgument, fmt::format("neither configuration fits: eye-in-hand: {} | eye-to-hand: {}",
                                                 ih.error().message, th.error().message));
  const bool pickIh = ih && (!th || ih->bestResult().pointRmsMm <= th->bestResult().pointRmsMm);
  HandEyeResult r = pickIh ? *ih : *th;
  const auto& other = pickIh ? th : ih;
  r.warnings.push_back(other ? fmt::format("configuration chosen by fit: the other one's best method fits at {:.3f} mm vs "
                                           "{:.3f} mm",
                                           other->bestResult().pointRmsMm, r.bestResult().pointRmsMm)
                             : fmt::format("configuration chosen by fit: the other one failed: {}", other.error().message));
  return r;
}

}  // namespace vgr::vision::calib
