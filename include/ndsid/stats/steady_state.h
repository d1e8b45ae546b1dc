// Closed-form steady-state estimate of EG from quasi-steady samples (physics.md §1):
//   d_sw = (is*l) * (a_y/v^2) + (is*EG) * a_y + d0          (without yaw rate)
//   d_sw = (is*l) * (r/v)     + (is*EG) * a_y + d0          (with yaw rate: kinematic term from r)
// An instant EG, a warm start for the dynamic fit and its own standard errors. Its regressors
// are noisy (errors in variables): expect a few per cent bias; the dynamic fit is the reference.
#pragma once

#include <string>

#include "ndsid/gate/gate.h"
#include "ndsid/stats/regression_stats.h"

namespace ndsid::stats {

struct SteadyStateEstimate {
  bool valid = false;
  std::string reason;
  double steer_ratio = 0;        // is
  double eg_rad_per_mps2 = 0;    // EG
  double eg_se = 0;              // standard error of EG (delta method)
  double steer_offset_rad = 0;   // d0 at the steering wheel
  double n = 0;
};

class SteadyStateStats {
 public:
  void Add(const gate::GatedSample& g) noexcept;  // uses only accepted quasi-steady samples
  void Merge(const SteadyStateStats& other) noexcept;
  void Forget(double factor) noexcept;
  SteadyStateEstimate Estimate(double wheelbase_m, bool use_yaw_rate) const;

  const RegressionStats& without_yaw() const { return without_yaw_; }
  const RegressionStats& with_yaw() const { return with_yaw_; }
  nlohmann::json ToJson() const;  // {"without_yaw": ..., "with_yaw": ...}
  static SteadyStateStats FromJson(const JsonIn& in);
  bool operator==(const SteadyStateStats&) const = default;

 private:
  RegressionStats without_yaw_;
  RegressionStats with_yaw_;
};

}  // namespace ndsid::stats
