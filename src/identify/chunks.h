// Segments cut into independently simulated chunks, and the Ceres cost functor over one chunk.
#pragma once

#include <ceres/dynamic_autodiff_cost_function.h>

#include <map>
#include <memory>
#include <vector>

#include "ndsid/identify/identifier.h"
#include "ndsid/model/simulate.h"

namespace ndsid::identify {

struct Chunk {
  const stats::SegmentSample* samples;
  size_t n;
  double dt_s;
  int64_t drive_id;
  std::shared_ptr<const std::vector<float>> bank;  // per sample of the chunk (empty: no yaw rate)
  double load_ratio = 1.0;                         // the drive's load ratio (load_change)

  model::InputSeries Inputs() const {
    constexpr size_t kStride = sizeof(stats::SegmentSample) / sizeof(float);
    model::InputSeries in{&samples[0].steer_rad, &samples[0].speed_mps, kStride, n, dt_s};
    in.load_ratio = load_ratio;
    if (bank && !bank->empty()) {
      in.bank_mps2 = bank->data();
      in.yaw_rate_radps = &samples[0].yaw_rate_radps;  // the bank is estimated only with a yaw rate
    }
    return in;
  }
};

// Road bank from the kinematic residual, g sin(theta) = v (beta' + r) - a_y,meas ~ v r - a_y,meas,
// low-passed forwards and backwards (zero phase) with time constant tau_s to remove the
// transient v beta' and the noise. Empty when the segment has no yaw rate.
std::vector<float> EstimateBank(const stats::Segment& segment, double tau_s = 1.0);

// Long segments are cut into chunks of about chunk_s (the last piece joins its predecessor
// when shorter than half a chunk); chunks with no residual after the burn-in are dropped.
// `loads`: load ratio per drive id (load_change); drives not listed get 1.
std::vector<Chunk> MakeChunks(const SegmentList& segments, double chunk_s, double burn_in_s,
                              const std::map<int64_t, double>& loads = {});
size_t BurnInSamples(const Chunk& c, double burn_in_s);

// Integrated autocorrelation time of residual series (1 + 2 sum of the autocorrelation up to
// the first lag where it turns negative), pooled over chunks, in samples.
double IntegratedAutocorrelationTime(const std::vector<std::vector<double>>& residuals_by_chunk);

// The noise level of residual series: sigma^2 (mean square) times their autocorrelation time;
// 0 without residuals.
double ResidualNoiseLevel(const std::vector<std::vector<double>>& residuals_by_chunk);

// A parameter vector of model `from` re-laid out for model `to`: shared parameters by name,
// the others at their neutral value.
std::vector<double> Extend(const model::ModelSpec& from, const std::vector<double>& values, const model::ModelSpec& to);

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
