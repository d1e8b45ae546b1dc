// The Ceres cost functor over one chunk (private to the identify stage).
#pragma once

#include <ceres/dynamic_autodiff_cost_function.h>

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

using ChunkCost = ceres::DynamicAutoDiffCostFunction<ChunkResidual, model::kJetSize>;

// weights: nullptr = a_y alone with weight 1 (the single-output fit, unchanged).
inline std::unique_ptr<ChunkCost> MakeChunkCost(const Chunk& c, size_t burn, double l, const model::ModelSpec& spec,
                                                const std::vector<double>& scale,
                                                std::shared_ptr<const OutputWeights> weights = nullptr) {
  if (!weights) weights = std::make_shared<const OutputWeights>();
  auto* functor = new ChunkResidual(c, burn, l, spec, scale, std::move(weights));
  auto cost = std::make_unique<ChunkCost>(functor);
  cost->AddParameterBlock(static_cast<int>(scale.size()));
  cost->SetNumResiduals(static_cast<int>(functor->num_residuals()));
  return cost;
}

}  // namespace ndsid::identify
