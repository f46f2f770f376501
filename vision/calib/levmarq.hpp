// Levenberg-Marquardt on a product of SE(3) factors with left-multiplicative se(3) updates
// T <- exp(xi) T (paper 003, eqs. 4-8), as hand-eye calibration uses it. Hand-written on
// Eigen: the problems are tiny (6 or 12 parameters, ~2000 residuals), need the manifold
// update that Eigen's unsupported LevenbergMarquardt (plain R^n) lacks, and Ceres is not one
// of our dependencies. Pure function, no state; poses in mm and radians (se3.hpp).
#pragma once

#include <functional>
#include <vector>

#include <Eigen/Core>

#include "vision/calib/se3.hpp"

namespace vgr::vision::calib {

// Minimises |f(params)|^2 over the poses in `params` (updated in place). Jacobians by central
// differences (1e-4 mm in translation, 1e-6 rad in rotation). Returns the final RMS of the
// residuals.
double levenbergMarquardt(std::vector<se3::Iso>& params,
                          const std::function<Eigen::VectorXd(const std::vector<se3::Iso>&)>& f, int maxIter = 50);

// One damped step of Levenberg-Marquardt with Marquardt's scaling: solves
// (JtJ + lambda diag(JtJ)) step = -g, the diagonal floored at 1e-9 (a parameter the residuals
// do not see). For LM loops with their own Jacobian structure (the joint hand-eye refinement).
Eigen::VectorXd dampedStep(const Eigen::MatrixXd& jtj, const Eigen::VectorXd& g, double lambda);

}  // namespace vgr::vision::calib
