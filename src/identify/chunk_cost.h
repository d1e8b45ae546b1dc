// The Ceres cost functor over one chunk (private to the identify stage).
#pragma once

#include <ceres/dynamic_autodiff_cost_function.h>

#include <memory>
#include <vector>

#include "ndsid/identify/chunks.h"

namespace ndsid::identify {

// Residuals e_k = a_y,meas,k - a_y,model,k of one chunk for k >= burn-in, as a function of the
// scaled parameters theta (p_i = theta_i * scale_i, so all unknowns are O(1) for the solver).
class ChunkResidual {
 public:
  ChunkResidual(const Chunk& chunk, size_t burn_in, double wheelbase_m, const model::ModelSpec& spec,
                std::vector<double> scale)
      : chunk_(chunk), burn_in_(burn_in), wheelbase_m_(wheelbase_m), spec_(spec), scale_(std::move(scale)) {}

  size_t num_residuals() const { return chunk_.n - burn_in_; }

  template <typename T>
  bool operator()(T const* const* theta, T* residuals) const {
    std::vector<T> p(scale_.size());
    for (size_t i = 0; i < scale_.size(); ++i) p[i] = theta[0][i] * scale_[i];
    std::vector<T> a_y(chunk_.n);
    model::SimulateModel(spec_, p.data(), wheelbase_m_, chunk_.Inputs(), a_y.data());
    const stats::SegmentSample* s = chunk_.samples;
    for (size_t k = burn_in_; k < chunk_.n; ++k) residuals[k - burn_in_] = T(static_cast<double>(s[k].lat_accel_mps2)) - a_y[k];
    return true;
  }

 private:
  Chunk chunk_;
  size_t burn_in_;
  double wheelbase_m_;
  const model::ModelSpec& spec_;
  std::vector<double> scale_;
};

using ChunkCost = ceres::DynamicAutoDiffCostFunction<ChunkResidual, model::kJetSize>;

inline std::unique_ptr<ChunkCost> MakeChunkCost(const Chunk& c, size_t burn, double l, const model::ModelSpec& spec,
                                                const std::vector<double>& scale) {
  auto* functor = new ChunkResidual(c, burn, l, spec, scale);
  auto cost = std::make_unique<ChunkCost>(functor);
  cost->AddParameterBlock(static_cast<int>(scale.size()));
  cost->SetNumResiduals(static_cast<int>(functor->num_residuals()));
  return cost;
}

}  // namespace ndsid::identify
