// Segments cut into independently simulated chunks (the unit of output-error simulation: each
// starts from rest after a burn-in), their residual noise level, and one chunk's residuals and
// Jacobian. No Ceres here: the cost functor is private to the identify stage (chunk_cost.h).
#pragma once

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
  std::vector<std::pair<int, double>> drive_params;  // the drive's per-drive values (DriveOverrides)

  // A finite measured yaw rate on every sample (the bank is estimated only then); without one
  // the chunk has a_y as its only output and road_bank is inert on it.
  bool has_yaw_rate() const { return bank && !bank->empty(); }

  model::InputSeries Inputs() const {
    constexpr size_t kStride = sizeof(stats::SegmentSample) / sizeof(float);
    model::InputSeries in{&samples[0].steer_rad, &samples[0].speed_mps, kStride, n, dt_s};
    if (bank && !bank->empty()) {
      in.bank_mps2 = bank->data();
      in.yaw_rate_radps = &samples[0].yaw_rate_radps;  // the bank is estimated only with a yaw rate
    }
    return in;
  }
  // The full parameter vector as this chunk's drive sees it: the per-drive entries replaced.
  template <typename T>
  void ApplyDriveParams(T* params) const {
    for (const auto& [i, v] : drive_params) params[i] = T(v);
  }
  std::vector<double> ParamsFor(std::vector<double> params) const {
    ApplyDriveParams(params.data());
    return params;
  }
};

// Road bank from the kinematic residual, g sin(theta) = v (beta' + r) - a_y,meas ~ v r - a_y,meas,
// low-passed forwards and backwards (zero phase) with time constant tau_s to remove the
// transient v beta' and the noise. Empty when the segment has no yaw rate or any sample's yaw
// rate is not finite (the segment is then fitted on a_y alone).
std::vector<float> EstimateBank(const stats::Segment& segment, double tau_s = 1.0);

// Long segments are cut into chunks of about chunk_s (the last piece joins its predecessor
// when shorter than half a chunk); chunks with no residual after the burn-in are dropped.
// `drive_values`: the per-drive parameter values of each drive (none: the vector's values).
std::vector<Chunk> MakeChunks(const SegmentList& segments, double chunk_s, double burn_in_s,
                              const DriveOverrides& drive_values = {});
size_t BurnInSamples(const Chunk& c, double burn_in_s);

// Autocorrelation sums sum_k e_k e_(k-lag), lags 0..kAcfMaxLag, of one series, added into acf
// (resized to kAcfMaxLag + 1): pooled over chunks by adding, and kept per chunk by the
// incremental update (linearized_window.h).
constexpr size_t kAcfMaxLag = 250;
void AddAutocorrelationSums(const std::vector<double>& e, std::vector<double>& acf);
// 1 + 2 sum of acf[lag]/acf[0] up to the first lag where it turns negative; 1 without data.
double AutocorrelationTimeFromSums(const std::vector<double>& acf);

// Integrated autocorrelation time of residual series (1 + 2 sum of the autocorrelation up to
// the first lag where it turns negative), pooled over chunks, in samples. Only the lags up to
// that one are summed; `threads` share the series (the result is the same for any number).
double IntegratedAutocorrelationTime(const std::vector<std::vector<double>>& residuals_by_chunk, int threads = 1);

// The noise level of residual series: sigma^2 (mean square) times their autocorrelation time;
// 0 without residuals.
double ResidualNoiseLevel(const std::vector<std::vector<double>>& residuals_by_chunk, int threads = 1);

// A parameter vector of model `from` re-laid out for model `to`: shared parameters by name,
// the others at their neutral value.
std::vector<double> Extend(const model::ModelSpec& from, const std::vector<double>& values, const model::ModelSpec& to);

// Residuals e (k >= burn) of one chunk of `spec` at the full parameter vector `params`, and
// their Jacobian d(a_y,meas - a_y,model)/d(params) (the chunk's per-drive values replace their
// entries of `params`, whose columns are then 0), row-major (residuals x spec.num_params()),
// by automatic differentiation. The discovery stage's score tests are built on it. With
// with_yaw_rate and a chunk that has a yaw rate, the yaw-rate residuals r_meas - r_model
// (unweighted) follow the a_y ones.
void EvaluateChunk(const Chunk& chunk, size_t burn, double wheelbase_m, const model::ModelSpec& spec,
                   const std::vector<double>& params, std::vector<double>& residuals, std::vector<double>& jacobian,
                   bool with_yaw_rate = false);

// Pointers to the segments, for the fitting functions.
SegmentList Pointers(const std::vector<stats::Segment>& segments);

}  // namespace ndsid::identify
