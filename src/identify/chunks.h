// Segments cut into independently simulated chunks, and the Ceres cost functor over one chunk.
#pragma once

#include <array>
#include <vector>

#include "ndsid/identify/identifier.h"
#include "ndsid/model/simulate.h"

namespace ndsid::identify {

struct Chunk {
  const stats::SegmentSample* samples;
  size_t n;
  double dt_s;
  int64_t drive_id;
};

// Long segments are cut into chunks of about chunk_s (the last piece joins its predecessor
// when shorter than half a chunk); chunks with no residual after the burn-in are dropped.
std::vector<Chunk> MakeChunks(const SegmentList& segments, double chunk_s, double burn_in_s);
size_t BurnInSamples(const Chunk& c, double burn_in_s);

// Residuals e_k = a_y,meas,k - a_y,model,k of one chunk for k >= burn-in, as a function of the
// scaled parameters theta (p_i = theta_i * scale_i, so all unknowns are O(1) for the solver).
class ChunkResidual {
 public:
  ChunkResidual(const Chunk& chunk, size_t burn_in, double wheelbase_m, const std::array<double, 6>& scale)
      : chunk_(chunk), burn_in_(burn_in), wheelbase_m_(wheelbase_m), scale_(scale) {}

  size_t num_residuals() const { return chunk_.n - burn_in_; }

  template <typename T>
  bool operator()(T const* const* theta, T* residuals) const {
    const T p[6] = {theta[0][0] * scale_[0], theta[0][1] * scale_[1], theta[0][2] * scale_[2],
                    theta[0][3] * scale_[3], theta[0][4] * scale_[4], theta[0][5] * scale_[5]};
    const model::Params<T> params = model::Params<T>::FromArray(p);
    std::vector<T> a_y(chunk_.n);
    const stats::SegmentSample* s = chunk_.samples;
    model::SimulateLateralAcceleration(
        params, wheelbase_m_, chunk_.dt_s, chunk_.n, [s](size_t k) { return static_cast<double>(s[k].steer_rad); },
        [s](size_t k) { return static_cast<double>(s[k].speed_mps); }, a_y.data());
    for (size_t k = burn_in_; k < chunk_.n; ++k) residuals[k - burn_in_] = T(static_cast<double>(s[k].lat_accel_mps2)) - a_y[k];
    return true;
  }

 private:
  Chunk chunk_;
  size_t burn_in_;
  double wheelbase_m_;
  std::array<double, 6> scale_;
};

}  // namespace ndsid::identify
