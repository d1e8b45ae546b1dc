// The incremental update's prior as a Ceres cost (private to the identify stage): the sum of
// the prior's chunk quadratics (linearized_window.h), and EG's gradient the update's guards use.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <vector>

#include "ndsid/identify/linearized_window.h"

namespace ndsid::identify {

// The sum of the prior's chunk quadratics, sum_c rss_c + 2 s_c'd_c + d_c' H_c d_c (d_c = theta -
// theta_c), as residuals A theta - c with A'A = H = sum H_c and A'c = b = sum (H_c theta_c - s_c):
// A = L^(1/2) V' over H's eigenpairs (V, L) above a relative floor.
// A direction the prior does not determine at all (L_k at the floor, e.g. a fixed parameter's or
// m's scaling direction when m is free) is held near the start theta0 (the last estimate) with a
// standard deviation of 1 (the parameter's scale) by a second row sqrt(level) v_k'(theta - theta0),
// so the solver cannot wander along it.
class QuadraticPrior final : public ceres::CostFunction {
 public:
  explicit QuadraticPrior(int np) : np_(np) {
    set_num_residuals(2 * np);
    mutable_parameter_block_sizes()->push_back(np);
  }
  int weak_directions() const { return weak_; }
  // The quadratics of `chunks`; level: the prior's noise level sigma^2 tau; theta0: the start.
  void Set(const std::vector<const LinearizedChunk*>& chunks, double level, const std::vector<double>& theta0);
  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    const Eigen::Map<const Eigen::VectorXd> theta(p[0], np_);
    Eigen::Map<Eigen::VectorXd>(r, 2 * np_) = a_ * theta - c_;
    if (jac && jac[0]) Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jac[0], 2 * np_, np_) = a_;
    return true;
  }

 private:
  int np_;
  Eigen::MatrixXd a_;
  Eigen::VectorXd c_;
  int weak_ = 0;
};

// d EG / d theta (scaled parameters, p_i = theta_i * scale_i) at theta: the six base parameters'
// entries, 0 for fixed ones (fixed[i]) and for effects.
Eigen::VectorXd EgGradientTheta(const std::vector<double>& theta, const std::vector<double>& scale, double wheelbase_m,
                                const std::vector<bool>& fixed);

}  // namespace ndsid::identify
