#include "ndsid/stats/steady_state.h"

#include <cmath>

#include "ndsid/common/error.h"

namespace ndsid::stats {

void SteadyStateStats::Add(const gate::GatedSample& g) noexcept {
  if (g.verdict != gate::Verdict::kAccepted) return;
  // A stretch ends at the first sample that is not quasi-steady and at every new segment (a gap
  // in the accepted samples, a new drive).
  if (!g.quasi_steady || g.segment_start) CloseStretch();
  if (!g.quasi_steady) return;
  const auto& s = g.sample;
  const double v = s.speed_mps;
  const double ay_v2 = s.lat_accel_mps2 / (v * v), r_v = s.yaw_rate_radps / v;
  if (!std::isfinite(ay_v2) || !std::isfinite(s.lat_accel_mps2) || !std::isfinite(s.steer_rad)) return;
  const bool yaw = s.has_yaw_rate && std::isfinite(r_v);
  open_.has_yaw_rate = (open_.n == 0 || open_.has_yaw_rate) && yaw;
  open_.n += 1;
  open_.steer += s.steer_rad;
  open_.ay_v2 += ay_v2;
  open_.ay += s.lat_accel_mps2;
  open_.r_v += yaw ? r_v : 0.0;
  open_.v_r += yaw ? v * s.yaw_rate_radps : 0.0;
}

void SteadyStateStats::CloseStretch() noexcept {
  const Stretch o = open_;
  open_ = Stretch{};
  if (!(o.n > 0)) return;
  const double k = 1.0 / o.n;
  without_yaw_.Add({o.ay_v2 * k, o.ay * k, 1.0}, o.steer * k, o.n);
  if (o.has_yaw_rate) {
    with_yaw_.Add({o.r_v * k, o.ay * k, 1.0}, o.steer * k, o.n);
    with_yaw_iv_.Add({o.r_v * k, o.ay * k, 1.0}, {o.r_v * k, o.v_r * k, 1.0}, o.steer * k, o.n);
  }
}

void SteadyStateStats::Merge(const SteadyStateStats& o) noexcept {
  // `o` holds later data: this one's stretch has ended, o's goes on.
  CloseStretch();
  without_yaw_.Merge(o.without_yaw_);
  with_yaw_.Merge(o.with_yaw_);
  with_yaw_iv_.Merge(o.with_yaw_iv_);
  open_ = o.open_;
}

void SteadyStateStats::Forget(double f) noexcept {
  without_yaw_.Forget(f);
  with_yaw_.Forget(f);
  with_yaw_iv_.Forget(f);
  open_.n *= f;
  open_.steer *= f;
  open_.ay_v2 *= f;
  open_.r_v *= f;
  open_.ay *= f;
  open_.v_r *= f;
}

SteadyStateStats SteadyStateStats::Closed() const {
  SteadyStateStats closed = *this;
  closed.CloseStretch();
  return closed;
}

RegressionStats SteadyStateStats::without_yaw() const { return Closed().without_yaw_; }
RegressionStats SteadyStateStats::with_yaw() const { return Closed().with_yaw_; }
InstrumentedStats SteadyStateStats::with_yaw_instrumented() const { return Closed().with_yaw_iv_; }

SteadyStateEstimate SteadyStateFromSolution(const LsSolution& s, double l) {
  SteadyStateEstimate e;
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
  e.steer_offset_se = std::sqrt(std::max(s.covariance[8], 0.0));
  // Delta method: EG = l*b/a, gradient (-l*b/a^2, l/a, 0).
  const double ga = -l * b / (a * a), gb = l / a;
  const double var = ga * ga * s.covariance[0] + 2 * ga * gb * s.covariance[1] + gb * gb * s.covariance[4];
  e.eg_se = std::sqrt(std::max(var, 0.0));
  e.valid = true;
  return e;
}

SteadyStateEstimate SteadyStateStats::Estimate(double l, bool use_yaw_rate) const {
  const SteadyStateStats c = Closed();
  // With the yaw rate, the instrumented regression once it has its observations (a state written
  // before it has none: the plain one stands in until then).
  const LsSolution s = !use_yaw_rate                 ? c.without_yaw_.Solve()
                       : c.with_yaw_iv_.m() >= 10 ? c.with_yaw_iv_.Solve()
                                                    : c.with_yaw_.Solve();
  return SteadyStateFromSolution(s, l);
}

nlohmann::json SteadyStateStats::ToJson() const {
  const Stretch& o = open_;
  nlohmann::json j = {{"without_yaw", without_yaw_.ToJson()}, {"with_yaw", with_yaw_.ToJson()}};
  if (with_yaw_iv_.m() > 0) j["with_yaw_instrumented"] = with_yaw_iv_.ToJson();
  if (o.n > 0)
    j["open_stretch"] = {{"n", o.n},   {"steer", o.steer}, {"ay_v2", o.ay_v2},
                         {"r_v", o.r_v}, {"ay", o.ay},       {"v_r", o.v_r}, {"has_yaw_rate", o.has_yaw_rate}};
  return j;
}

SteadyStateStats SteadyStateStats::FromJson(const JsonIn& in) {
  SteadyStateStats s;
  s.without_yaw_ = RegressionStats::FromJson(in.At("without_yaw"));
  s.with_yaw_ = RegressionStats::FromJson(in.At("with_yaw"));
  if (in.Has("with_yaw_instrumented")) s.with_yaw_iv_ = InstrumentedStats::FromJson(in.At("with_yaw_instrumented"));
  if (in.Has("open_stretch")) {  // absent in a state written before stretches: none open
    const JsonIn o = in.At("open_stretch");
    Stretch& t = s.open_;
    t.n = o.Finite("n");
    if (t.n < 0) o.At("n").Fail("negative");
    t.steer = o.Finite("steer");
    t.ay_v2 = o.Finite("ay_v2");
    t.r_v = o.Finite("r_v");
    t.ay = o.Finite("ay");
    t.v_r = o.Finite("v_r");
    t.has_yaw_rate = o.Bool("has_yaw_rate");
  }
  return s;
}

}  // namespace ndsid::stats
