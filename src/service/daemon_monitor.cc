#include <algorithm>
#include <cmath>

#include "daemon_monitor.h"
#include "ndsid/identify/model_output.h"
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

void ModelMonitor::SetModel(std::shared_ptr<const identify::Identifier> model, std::vector<double> params) {
  model_ = std::move(model);
  model_params_ = std::move(params);
  if (model_ && model_->spec().effects().empty()) model_.reset();  // the linear model does the same, per sample
  if (model_) {
    window_.dt_s = 1.0 / model_->config().rate_hz;
    window_decimation_ = std::max(1, static_cast<int>(std::lround(window_.dt_s / period_s_)));
    window_.dt_s = window_decimation_ * period_s_;
    window_.samples.clear();
    window_.samples.reserve(2 * static_cast<size_t>(kWindow_s / window_.dt_s) + 2);  // no allocation in Observe
  }
  window_running_ = false;
}

bool ModelMonitor::EffectsModelOutput(double& a_y, double& r) noexcept {
  const double needed_s = model_->config().burn_in_s + 1.0;  // settled past the burn-in
  if (window_.duration_s() < needed_s) return false;
  try {
    const identify::SegmentList one{&window_};
    const auto out = identify::SimulateChunks(*model_, model_params_, one);
    if (out.empty() || out.back().a_y_model_mps2.empty()) return false;
    const auto& c = out.back();
    if (c.first + c.n != window_.samples.size()) return false;  // the newest sample is not simulated
    a_y = c.a_y_model_mps2.back();
    r = c.yaw_rate_model_radps.empty() ? 0.0 : c.yaw_rate_model_radps.back();
    return std::isfinite(a_y) && std::isfinite(r);
  } catch (...) {  // out of memory: no model value this time
    return false;
  }
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
  if (model_) {
    // The recent gated samples at the identification rate, for the model with effects.
    const double gap = static_cast<double>(s.t_ns - prev_t_ns_) * 1e-9;
    if (!accepted || g.segment_start || g.new_drive || gap <= 0 || gap > 2.5 * period_s_) {
      window_.samples.clear();
      window_running_ = false;
      window_count_ = 0;
    }
    if (accepted) {
      if (!window_running_) {
        window_running_ = true;
        window_.t0_ns = s.t_ns;
        window_.drive_id = g.drive_id;
        window_.has_yaw_rate = s.has_yaw_rate;
      }
      if (window_count_++ % window_decimation_ == 0) {
        window_.samples.push_back({static_cast<float>(s.steer_rad), static_cast<float>(s.speed_mps),
                                   static_cast<float>(s.lat_accel_mps2), static_cast<float>(s.yaw_rate_radps),
                                   static_cast<float>(s.long_accel_mps2)});
        const size_t max_n = static_cast<size_t>(kWindow_s / window_.dt_s);
        if (window_.samples.size() > 2 * max_n) {  // drop the oldest half at once (amortised O(1))
          const size_t drop = window_.samples.size() - max_n;
          window_.samples.erase(window_.samples.begin(), window_.samples.begin() + static_cast<long>(drop));
          window_.t0_ns += static_cast<int64_t>(1e9 * window_.dt_s * static_cast<double>(drop));
        }
      }
    }
  }
  prev_steer_ = s.steer_rad;
  prev_speed_ = s.speed_mps;
  prev_t_ns_ = s.t_ns;
  if (++count_ < decimation_) return std::nullopt;
  count_ = 0;
  pending_model_ = model_ && accepted && window_running_;
  if (model_) model_valid = false;  // FillModel
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

void ModelMonitor::FillModel(publish::MonitorMessage& m) noexcept {
  if (!pending_model_) return;
  pending_model_ = false;
  double a_y = 0, r = 0;
  m.model_valid = EffectsModelOutput(a_y, r);
  m.lat_accel_model_mps2 = m.model_valid ? a_y : 0.0;
  m.yaw_rate_model_radps = m.model_valid ? r : 0.0;
}

}  // namespace ndsid::service
