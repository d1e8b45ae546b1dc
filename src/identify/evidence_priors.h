// Evidence priors of a window fit (private to the identify stage): Gaussian priors on single
// parameters from outside the fitted residuals, each one residual of the least-squares problem.
#pragma once

#include <ceres/ceres.h>

#include <algorithm>
#include <cmath>
#include <string>

#include "ndsid/config/config.h"

namespace ndsid::identify {

// A Gaussian prior on parameter i as one residual sqrt(w) (theta_i scale_i - value) / sd, with w
// the data's noise level (sigma_e^2 times the residuals' autocorrelation time) so that the sum
// of squares stays the MAP objective of the data's least squares.
class PriorCost final : public ceres::CostFunction {
 public:
  PriorCost(int np, int i, double scale, double value, double sd) : i_(i), scale_(scale), value_(value), sd_(sd) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(np);
  }
  void set_weight(double w) { sqrt_w_ = std::sqrt(w); }
  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    r[0] = sqrt_w_ * (p[0][i_] * scale_ - value_) / sd_;
    if (jac && jac[0]) {
      std::fill(jac[0], jac[0] + parameter_block_sizes()[0], 0.0);
      jac[0][i_] = sqrt_w_ * scale_ / sd_;
    }
    return true;
  }
  int index() const { return i_; }
  double information_theta() const { return scale_ * scale_ / (sd_ * sd_); }  // 1/var in theta space

 private:
  int i_;
  double scale_, value_, sd_;
  double sqrt_w_ = 0;
};

// Whether model.priors has a prior on the parameter `name` (it then wins over model-free evidence).
bool HasConfiguredPrior(const config::IdentificationConfig& config, const std::string& name);

}  // namespace ndsid::identify
