// Closed-form steady-state estimate of EG from quasi-steady samples (physics.md §1):
//   d_sw = (is*l) * (a_y/v^2) + (is*EG) * a_y + d0          (without yaw rate)
//   d_sw = (is*l) * (r/v)     + (is*EG) * a_y + d0          (with yaw rate: kinematic term from r)
// An instant EG, a warm start for the dynamic fit and its own standard errors.
// One observation per quasi-steady stretch (a contiguous run of accepted quasi-steady samples):
// the stretch's means, weighted by its sample count. Averaging takes the sensors' noise and
// vibration out of the regressors (per sample they would attenuate the coefficients: errors in
// variables), and the residual variance counts stretches, not correlated samples, as degrees of
// freedom. What remains (a bank, wind, the dynamics of a stretch that is not quite steady) is a few
// per cent; the dynamic fit is the reference.
// With the yaw rate, a_y is instrumented by v*r (instrumental variables): in steady state the two
// agree but for the road's bank, and v*r carries none of the accelerometer's noise, which would
// otherwise still attenuate the a_y coefficient where it lies inside a filter's pass band.
#pragma once

#include <string>

#include "ndsid/gate/gate.h"
#include "ndsid/stats/instrumented_stats.h"
#include "ndsid/stats/regression_stats.h"

namespace ndsid::stats {

struct SteadyStateEstimate {
  bool valid = false;
  std::string reason;
  double steer_ratio = 0;        // is
  double eg_rad_per_mps2 = 0;    // EG
  double eg_se = 0;              // standard error of EG (delta method)
  double steer_offset_rad = 0;   // d0 at the steering wheel
  double steer_offset_se = 0;    // its standard error (stretches as degrees of freedom)
  double n = 0;
};

// is, EG (delta-method standard error) and d0 from a solution for theta = (is*l, is*EG, d0).
SteadyStateEstimate SteadyStateFromSolution(const LsSolution& solution, double wheelbase_m);

class SteadyStateStats {
 public:
  void Add(const gate::GatedSample& g) noexcept;  // uses only accepted quasi-steady samples
  void Merge(const SteadyStateStats& other) noexcept;
  void Forget(double factor) noexcept;
  SteadyStateEstimate Estimate(double wheelbase_m, bool use_yaw_rate) const;

  // The regressions' statistics, the open stretch included as if it ended here.
  RegressionStats without_yaw() const;
  RegressionStats with_yaw() const;
  InstrumentedStats with_yaw_instrumented() const;
  nlohmann::json ToJson() const;  // {"without_yaw": ..., "with_yaw": ...}
  static SteadyStateStats FromJson(const JsonIn& in);
  bool operator==(const SteadyStateStats&) const = default;

  // The stretch still open (its sums): it counts in Estimate() and travels in the state.
  struct Stretch {
    double n = 0;            // samples (forgetting scales it like the rest)
    double steer = 0;        // sum of d_sw
    double ay_v2 = 0;        // sum of a_y / v^2
    double r_v = 0;          // sum of r / v (samples with a yaw rate)
    double ay = 0;           // sum of a_y
    double v_r = 0;          // sum of v * r (samples with a yaw rate)
    bool has_yaw_rate = true;
    bool operator==(const Stretch&) const = default;
  };

 private:
  void CloseStretch() noexcept;  // adds the open stretch's means as one observation
  SteadyStateStats Closed() const;  // a copy with the open stretch closed
  RegressionStats without_yaw_;
  RegressionStats with_yaw_;
  InstrumentedStats with_yaw_iv_;  // empty in a state written before it: with_yaw_ stands in
  Stretch open_;
};

}  // namespace ndsid::stats
