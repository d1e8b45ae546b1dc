#include <algorithm>
#include <cmath>

#include "daemon_monitor.h"
#include "ndsid/model/simulate.h"

namespace ndsid::service {

ModelMonitor::ModelMonitor(double wheelbase_m, double sync_rate_hz, double monitor_rate_hz)
    : wheelbase_m_(wheelbase_m),
      period_s_(1.0 / sync_rate_hz),
      decimation_(std::max(1, static_cast<int>(std::lround(sync_rate_hz / monitor_rate_hz)))) {}

void ModelMonitor::SetParams(const std::optional<model::Params<double>>& params) {
  params_ = params;
  running_ = false;  // restart from the steady state with the new parameters
}

std::optional<publish::MonitorMessage> ModelMonitor::Observe(const gate::GatedSample& g) noexcept {
  const sync::Sample& s = g.sample;
  const bool accepted = g.verdict == gate::Verdict::kAccepted;
  double ay_model = 0, r_model = 0;
  bool model_valid = false;
  if (accepted && params_) {
    const double dt = static_cast<double>(s.t_ns - prev_t_ns_) * 1e-9;
    // Reset at segment starts and after any hole in the sample grid: the model's state is
    // unknown there, so start from the steady state of the current inputs (as the fit does).
    if (!running_ || g.segment_start || g.new_drive || dt <= 0 || dt > 2.5 * period_s_) {
      x_ = model::SteadyState(*params_, wheelbase_m_, s.steer_rad, s.speed_mps);
      running_ = true;
    } else {
      model::Rk4Step(*params_, wheelbase_m_, x_, prev_steer_, s.steer_rad, prev_speed_, s.speed_mps, dt);
    }
    ay_model = model::LinearDerivative(*params_, wheelbase_m_, x_, s.steer_rad, s.speed_mps).a_y;
    r_model = x_.r;
    model_valid = std::isfinite(ay_model) && std::isfinite(r_model);
    if (!model_valid) running_ = false;
  } else {
    running_ = false;
  }
  prev_steer_ = s.steer_rad;
  prev_speed_ = s.speed_mps;
  prev_t_ns_ = s.t_ns;
  if (++count_ < decimation_) return std::nullopt;
  count_ = 0;
  publish::MonitorMessage m;
  m.utime = s.t_ns / 1000;
  m.lat_accel_mps2 = s.lat_accel_mps2;
  m.yaw_rate_radps = s.has_yaw_rate ? s.yaw_rate_radps : 0.0;
  m.speed_mps = s.speed_mps;
  m.steer_rad = s.steer_rad;
  m.model_valid = model_valid;
  m.lat_accel_model_mps2 = model_valid ? ay_model : 0.0;
  m.yaw_rate_model_radps = model_valid ? r_model : 0.0;
  m.verdict = gate::VerdictName(g.verdict);
  return m;
}

}  // namespace ndsid::service
