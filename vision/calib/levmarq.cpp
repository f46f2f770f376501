#include "vision/calib/levmarq.hpp"

#include <algorithm>
#include <cmath>

#include <Eigen/Dense>

namespace vgr::vision::calib {

using se3::Iso;

double levenbergMarquardt(std::vector<Iso>& params, const std::function<Eigen::VectorXd(const std::vector<Iso>&)>& f,
                          int maxIter) {
  const int np = static_cast<int>(params.size()) * 6;
  Eigen::VectorXd r = f(params);
  double cost = r.squaredNorm();
  double lambda = 1e-3;
  auto perturbed = [&](const std::vector<Iso>& base, const Eigen::VectorXd& delta) {
    std::vector<Iso> out = base;
    for (std::size_t k = 0; k < out.size(); ++k)
      out[k] = se3::expSe3(delta.segment<6>(static_cast<Eigen::Index>(6 * k))) * out[k];
    return out;
  };
  for (int it = 0; it < maxIter; ++it) {
    Eigen::MatrixXd jac(r.size(), np);
    for (int c = 0; c < np; ++c) {
      // Step: 1e-4 mm in translation, 1e-6 rad in rotation (both well above rounding).
      const double h = (c % 6) < 3 ? 1e-4 : 1e-6;
      Eigen::VectorXd dp = Eigen::VectorXd::Zero(np), dm = Eigen::VectorXd::Zero(np);
      dp(c) = h;
      dm(c) = -h;
      jac.col(c) = (f(perturbed(params, dp)) - f(perturbed(params, dm))) / (2 * h);
    }
    const Eigen::MatrixXd jtj = jac.transpose() * jac;
    const Eigen::VectorXd g = jac.transpose() * r;
    bool improved = false;
    for (int tries = 0; tries < 10 && !improved; ++tries) {
      const Eigen::VectorXd step = dampedStep(jtj, g, lambda);
      const std::vector<Iso> cand = perturbed(params, step);
      const Eigen::VectorXd rc = f(cand);
      const double cc = rc.squaredNorm();
      if (std::isfinite(cc) && cc < cost) {
        const double rel = (cost - cc) / std::max(cost, 1e-30);
        params = cand;
        r = rc;
        cost = cc;
        lambda = std::max(lambda / 10, 1e-12);
        improved = true;
        if (rel < 1e-12) return std::sqrt(cost / static_cast<double>(r.size()));
      } else {
        lambda *= 10;
      }
    }
    if (!improved) break;
  }
  return std::sqrt(cost / static_cast<double>(r.size()));
}

Eigen::VectorXd dampedStep(const Eigen::MatrixXd& jtj, const Eigen::VectorXd& g, double lambda) {
  Eigen::MatrixXd aug = jtj;
  aug.diagonal() += lambda * jtj.diagonal().cwiseMax(1e-9);
  return -aug.ldlt().solve(g);
}

}  // namespace vgr::vision::calib
