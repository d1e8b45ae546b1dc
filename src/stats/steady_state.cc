#include "ndsid/stats/steady_state.h"

#include <cmath>

#include "ndsid/common/error.h"

namespace ndsid::stats {

void SteadyStateStats::Add(const gate::GatedSample& g) noexcept {
  if (g.verdict != gate::Verdict::kAccepted || !g.quasi_steady) return;
  const auto& s = g.sample;
  const double v = s.speed_mps;
  without_yaw_.Add({s.lat_accel_mps2 / (v * v), s.lat_accel_mps2, 1.0}, s.steer_rad);
  if (s.has_yaw_rate) with_yaw_.Add({s.yaw_rate_radps / v, s.lat_accel_mps2, 1.0}, s.steer_rad);
}

void SteadyStateStats::Merge(const SteadyStateStats& o) noexcept {
  without_yaw_.Merge(o.without_yaw_);
  with_yaw_.Merge(o.with_yaw_);
}

void SteadyStateStats::Forget(double f) noexcept {
  without_yaw_.Forget(f);
  with_yaw_.Forget(f);
}

SteadyStateEstimate SteadyStateStats::Estimate(double l, bool use_yaw_rate) const {
  SteadyStateEstimate e;
  const LsSolution s = (use_yaw_rate ? with_yaw_ : without_yaw_).Solve();
  e.n = s.n;
  if (!s.valid) {
    e.reason = s.reason;
    return e;
  }
  const double a = s.theta[0], b = s.theta[1];  // a = is*l, b = is*EG
  if (!(a > 0)) {
    e.reason = "non-positive steering ratio estimate";
    return e;
  }
  e.steer_ratio = a / l;
  e.eg_rad_per_mps2 = b * l / a;
  e.steer_offset_rad = s.theta[2];
  // Delta method: EG = l*b/a, gradient (-l*b/a^2, l/a, 0).
  const double ga = -l * b / (a * a), gb = l / a;
  const double var = ga * ga * s.covariance[0] + 2 * ga * gb * s.covariance[1] + gb * gb * s.covariance[4];
  e.eg_se = std::sqrt(std::max(var, 0.0));
  e.valid = true;
  return e;
}

nlohmann::json SteadyStateStats::ToJson() const {
  return {{"without_yaw", without_yaw_.ToJson()}, {"with_yaw", with_yaw_.ToJson()}};
}

SteadyStateStats SteadyStateStats::FromJson(const JsonIn& in) {
  SteadyStateStats s;
  s.without_yaw_ = RegressionStats::FromJson(in.At("without_yaw"));
  s.with_yaw_ = RegressionStats::FromJson(in.At("with_yaw"));
  return s;
}

}  // namespace ndsid::stats
