// The Ceres cost functor over one chunk (private to the identify stage).
#pragma once

#include <ceres/dynamic_autodiff_cost_function.h>

#include <Eigen/Dense>

#include <algorithm>
#include <cmath>
#include <cstring>
#include <memory>
#include <vector>

#include "ndsid/identify/chunks.h"

namespace ndsid::identify {

// The weight of each output's residuals (1 / sqrt of its noise level sigma^2 tau); yaw_rate 0:
// the yaw rate is not an output (a_y alone). Shared by all chunks of a problem, so the
// identifier can re-weight between solves.
struct OutputWeights {
  double a_y = 1.0;
  double yaw_rate = 0.0;
};

// Residuals of one chunk for k >= burn-in, as a function of the scaled parameters theta
// (p_i = theta_i * scale_i, so all unknowns are O(1) for the solver), stacked per output:
//   w_a (a_y,meas,k - a_y,model,k)   for k = burn .. n-1, then, when the yaw rate is an output
//   and the chunk has one,
//   w_r (r_meas,k - r_model,k)       for k = burn .. n-1  (r_model includes gyro_offset, gyro_scale)
class ChunkResidual {
 public:
  ChunkResidual(const Chunk& chunk, size_t burn_in, double wheelbase_m, const model::ModelSpec& spec,
                std::vector<double> scale, std::shared_ptr<const OutputWeights> weights)
      : chunk_(chunk), burn_in_(burn_in), wheelbase_m_(wheelbase_m), spec_(spec), scale_(std::move(scale)),
        weights_(std::move(weights)), yaw_(weights_->yaw_rate > 0 && chunk.has_yaw_rate()) {}

  size_t num_a_y_residuals() const { return chunk_.n - burn_in_; }
  bool yaw_rate_output() const { return yaw_; }
  size_t num_residuals() const { return (yaw_ ? 2 : 1) * num_a_y_residuals(); }

  template <typename T>
  bool operator()(T const* const* theta, T* residuals) const {
    std::vector<T> p(scale_.size());
    for (size_t i = 0; i < scale_.size(); ++i) p[i] = theta[0][i] * scale_[i];
    chunk_.ApplyDriveParams(p.data());
    std::vector<T> a_y(chunk_.n), r(yaw_ ? chunk_.n : 0);
    model::SimulateModel(spec_, p.data(), wheelbase_m_, chunk_.Inputs(), a_y.data(), nullptr,
                         yaw_ ? r.data() : nullptr);
    const stats::SegmentSample* s = chunk_.samples;
    const T wa(weights_->a_y), wr(weights_->yaw_rate);
    const size_t m = num_a_y_residuals();
    for (size_t k = burn_in_; k < chunk_.n; ++k) {
      residuals[k - burn_in_] = wa * (T(static_cast<double>(s[k].lat_accel_mps2)) - a_y[k]);
      if (yaw_) residuals[m + k - burn_in_] = wr * (T(static_cast<double>(s[k].yaw_rate_radps)) - r[k]);
    }
    return true;
  }

 private:
  Chunk chunk_;
  size_t burn_in_;
  double wheelbase_m_;
  const model::ModelSpec& spec_;
  std::vector<double> scale_;
  std::shared_ptr<const OutputWeights> weights_;
  bool yaw_;
};

// A chunk's cost with its Jacobian by automatic differentiation: in one pass of the narrower
// SmallJet for a model of at most model::kSmallJetSize parameters, else in passes of model::Jet
// (effect.h).
using ChunkCost = ceres::DynamicCostFunction;

// weights: nullptr = a_y alone with weight 1 (the single-output fit, unchanged).
inline std::unique_ptr<ChunkCost> MakeChunkCost(const Chunk& c, size_t burn, double l, const model::ModelSpec& spec,
                                                const std::vector<double>& scale,
                                                std::shared_ptr<const OutputWeights> weights = nullptr) {
  if (!weights) weights = std::make_shared<const OutputWeights>();
  auto* functor = new ChunkResidual(c, burn, l, spec, scale, std::move(weights));
  std::unique_ptr<ChunkCost> cost;  // owns the functor
  if (scale.size() <= static_cast<size_t>(model::kSmallJetSize)) {
    cost = std::make_unique<ceres::DynamicAutoDiffCostFunction<ChunkResidual, model::kSmallJetSize>>(functor);
  } else {
    cost = std::make_unique<ceres::DynamicAutoDiffCostFunction<ChunkResidual, model::kJetSize>>(functor);
  }
  cost->AddParameterBlock(static_cast<int>(scale.size()));
  cost->SetNumResiduals(static_cast<int>(functor->num_residuals()));
  return cost;
}

// A chunk's cost as Ceres sees it: its m residuals r and Jacobian J (m x np) replaced by the
// np + 1 residuals [Q'r; s] with Jacobian [R; 0], where J = QR (thin Householder QR) and
// s^2 = |r|^2 - |Q'r|^2. At the evaluation point the two give the same cost |r|^2 / 2, gradient
// J'r = R'Q'r and Gauss-Newton matrix J'J = R'R, so the same trust-region step: the solver's
// iterates are those of the full residuals to rounding (about 1e-16 relative), while its Jacobian
// has np + 1 rows per chunk instead of m (at 20 gated hours 3.5 million rows: 200 MB). A
// residual-only evaluation returns [0; |r|], the same cost.
//
// It also keeps its last evaluation with a Jacobian. Ceres's trust-region minimizer with bounds
// evaluates the Jacobian twice at every point it accepts: in its projected line search (whose
// cubic interpolation needs the gradient at the trial point) and again on accepting it. The
// repeat is a copy here, answered only at bit-identical parameters and output weights.
//
// With keep_last(true) it also keeps that evaluation's own residuals and Jacobian (m and m x np
// values), which TakeLast hands to the statistics at the optimum: the solver's last accepted
// point is that optimum, so its chunks need not be simulated there again.
//
// full() is the chunk's own cost, for the identifier's passes that need the residual series.
// One instance is evaluated by one thread at a time (Ceres evaluates each residual block on one
// thread; the identifier's passes give each chunk to one).
class CompressedChunkCost : public ceres::CostFunction {
 public:
  CompressedChunkCost(std::unique_ptr<ChunkCost> cost, std::shared_ptr<const OutputWeights> weights)
      : cost_(std::move(cost)), weights_(std::move(weights)) {
    *mutable_parameter_block_sizes() = cost_->parameter_block_sizes();
    set_num_residuals(cost_->parameter_block_sizes()[0] + 1);
  }

  const ChunkCost& full() const { return *cost_; }
  void keep_last(bool keep) { keep_last_ = keep; }

  // The residuals e and Jacobian jac (row-major, m x np) of the last evaluation with a Jacobian
  // if it was at bit-identical parameters and output weights (and kept); false otherwise. Moves
  // them out: a second call returns false.
  bool TakeLast(const double* theta, std::vector<double>& e, std::vector<double>& jac) const {
    if (last_e_.empty() || !CachedAt(theta, *weights_)) return false;
    e = std::move(last_e_);
    jac = std::move(last_jac_);
    last_e_.clear();
    last_jac_.clear();
    return true;
  }

  bool Evaluate(double const* const* parameters, double* residuals, double** jacobians) const override {
    const int np = cost_->parameter_block_sizes()[0], m = cost_->num_residuals();
    if (jacobians == nullptr || jacobians[0] == nullptr) {
      std::vector<double> e(static_cast<size_t>(m));
      if (!cost_->Evaluate(parameters, e.data(), nullptr)) return false;
      std::fill(residuals, residuals + np, 0.0);
      residuals[np] = Eigen::Map<const Eigen::VectorXd>(e.data(), m).norm();
      return std::isfinite(residuals[np]);
    }
    const OutputWeights w = *weights_;
    const size_t n_rho = static_cast<size_t>(np) + 1;
    if (!CachedAt(parameters[0], w)) {
      valid_ = false;
      last_e_.clear();
      last_jac_.clear();
      std::vector<double> e(static_cast<size_t>(m)), jac(static_cast<size_t>(m) * np);
      double* jacs[] = {jac.data()};
      if (!cost_->Evaluate(parameters, e.data(), jacs)) return false;
      const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(jac.data(), m, np);
      const Eigen::Map<const Eigen::VectorXd> ev(e.data(), m);
      const Eigen::HouseholderQR<Eigen::MatrixXd> qr(J);
      const int k = std::min(m, np);
      const Eigen::VectorXd qtr = qr.householderQ().adjoint() * ev;
      rho_.assign(n_rho, 0.0);
      jac_.assign(n_rho * static_cast<size_t>(np), 0.0);
      for (int i = 0; i < k; ++i) {
        rho_[static_cast<size_t>(i)] = qtr[i];
        for (int j = i; j < np; ++j) jac_[static_cast<size_t>(i) * np + j] = qr.matrixQR()(i, j);
      }
      rho_[static_cast<size_t>(np)] = std::sqrt(std::max(0.0, ev.squaredNorm() - qtr.head(k).squaredNorm()));
      if (!std::isfinite(rho_[static_cast<size_t>(np)])) return false;
      theta_.assign(parameters[0], parameters[0] + np);
      weights_at_ = w;
      valid_ = true;
      if (keep_last_) {
        last_e_ = std::move(e);
        last_jac_ = std::move(jac);
      }
    }
    std::memcpy(residuals, rho_.data(), n_rho * sizeof(double));
    std::memcpy(jacobians[0], jac_.data(), n_rho * static_cast<size_t>(np) * sizeof(double));
    return true;
  }

 private:
  // Whether the last evaluation with a Jacobian was at bit-identical parameters and weights.
  bool CachedAt(const double* theta, const OutputWeights& w) const {
    const size_t np = static_cast<size_t>(cost_->parameter_block_sizes()[0]);
    return valid_ && std::memcmp(theta, theta_.data(), np * sizeof(double)) == 0 && std::memcmp(&w, &weights_at_, sizeof w) == 0;
  }

  std::unique_ptr<ChunkCost> cost_;
  std::shared_ptr<const OutputWeights> weights_;
  mutable bool valid_ = false;
  mutable std::vector<double> theta_, rho_, jac_;  // the last evaluation with a Jacobian: [Q'r; s], [R; 0]
  mutable OutputWeights weights_at_;
  bool keep_last_ = false;
  mutable std::vector<double> last_e_, last_jac_;  // that evaluation's own residuals and Jacobian (keep_last)
};

}  // namespace ndsid::identify
