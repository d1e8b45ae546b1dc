#include "sensors.h"

#include <algorithm>
#include <cmath>

#include "ndsid/model/single_track.h"

namespace ndsid::sim {

namespace {
constexpr double kDeg = M_PI / 180.0;
constexpr double kValidAfter_s = 0.3;  // sensors report "invalid" during initialisation after key-on
}  // namespace

SensorModel::Tones SensorModel::DrawTones(Rng& rng) {
  Tones tones{};
  double power = 0;
  for (Tone& t : tones) {
    t.hz = rng.Uniform(15.0, 35.0);
    t.phase_rad = rng.Uniform(0.0, 2 * M_PI);
    t.amplitude = rng.Uniform(0.5, 1.0);
    power += 0.5 * t.amplitude * t.amplitude;
  }
  for (Tone& t : tones) t.amplitude /= std::sqrt(power);  // unit RMS
  return tones;
}

double SensorModel::Vibration(const Tones& tones, double t_s) {
  double x = 0;
  for (const Tone& t : tones) x += t.amplitude * std::sin(2 * M_PI * t.hz * t_s + t.phase_rad);
  return x;
}

SensorModel::SensorModel(const config::SimulationConfig& cfg, double dt_step_s, Rng& rng, uint64_t vibration_seed)
    : cfg_(cfg),
      dt_step_s_(dt_step_s),
      rng_(rng),
      disturbance_(cfg.noise.lat_accel_disturbance_mps2, cfg.noise.lat_accel_disturbance_tau_s),
      mu_esp_(cfg.effects.tyre_mu > 0.0 ? cfg.effects.tyre_mu : 1.0) {
  disturbance_.Reset(rng_);
  Rng vibration_rng(vibration_seed);
  accel_tones_ = DrawTones(vibration_rng);
  gyro_tones_ = DrawTones(vibration_rng);
}

void SensorModel::PushSteer(double steer_sw_rad) { steer_history_.push_back(steer_sw_rad); }

double SensorModel::SteerAt(double t_s) const {
  const double x = std::clamp(t_s / dt_step_s_, 0.0, static_cast<double>(steer_history_.size() - 1));
  const size_t i = static_cast<size_t>(x);
  if (i + 1 >= steer_history_.size()) return steer_history_.back();
  const double f = x - static_cast<double>(i);
  return steer_history_[i] + f * (steer_history_[i + 1] - steer_history_[i]);
}

double SensorModel::Delayed(std::deque<double>& history, double now, double delay_s) {
  constexpr size_t kMaxDelaySamples = static_cast<size_t>(1.0 * kOutputRate_hz) + 2;  // 1 s, the configuration's limit
  history.push_back(now);
  if (history.size() > kMaxDelaySamples) history.pop_front();
  if (delay_s <= 0.0) return now;
  const double x = std::max(0.0, static_cast<double>(history.size() - 1) - delay_s * kOutputRate_hz);
  const size_t i = static_cast<size_t>(x);
  if (i + 1 >= history.size()) return history.back();
  const double f = x - static_cast<double>(i);
  return history[i] + f * (history[i + 1] - history[i]);
}

void SensorModel::Record(const SampleTruth& st, uint8_t gear, DriveSeries& out) {
  const auto& fx = cfg_.effects;
  const auto& nz = cfg_.noise;
  const double g = model::kGravity_mps2;
  // The same number of draws whatever the effects and noise levels (effect on/off runs match).
  const double n_steer = rng_.Normal(), n_speed = rng_.Normal(), n_ay = rng_.Normal(), n_ax = rng_.Normal(),
               n_r = rng_.Normal();
  double n_wheel[4];
  for (double& n : n_wheel) n = rng_.Normal();
  const double disturbance = disturbance_.Step(rng_, 1.0 / kOutputRate_hz);

  out.t_s.push_back(st.t);
  out.steer_sw_rad.push_back(st.steer);
  out.speed_mps.push_back(st.v);
  out.a_y_mps2.push_back(st.a_y);
  out.yaw_rate_radps.push_back(st.r);
  out.yaw_accel_radps2.push_back(st.r_dot);
  out.side_slip_rad.push_back(st.beta);
  out.a_x_mps2.push_back(st.a_x);
  out.roll_rad.push_back(st.roll);
  out.bank_rad.push_back(st.bank);
  out.curvature_1pm.push_back(st.kappa);
  out.s_m.push_back(st.s);
  out.lateral_offset_m.push_back(st.e);
  out.lane_target_m.push_back(st.e_target);
  out.heading_error_rad.push_back(st.psi);
  out.reverse.push_back(st.reverse ? 1 : 0);

  // Steering: the message carries the value from steer_delay_ms earlier, offset at the wheel.
  const double delay_s = fx.steer_delay_ms / 1000.0;
  const double steer_delayed = SteerAt(st.t - delay_s);
  out.steer_sw_meas_rad.push_back(steer_delayed + fx.steer_offset_deg * kDeg + nz.steer_deg * kDeg * n_steer);
  out.steer_rate_meas_radps.push_back((steer_delayed - SteerAt(st.t - delay_s - 0.01)) / 0.01);

  // Speed: wheel-based, scaled by (1 + eps), never negative, exactly 0 at standstill. The
  // vehicle speed signal (not the wheel speeds) reaches the bus speed_delay_ms late (an exact
  // delay of what it sensed) and carries speed_offset_kph while the car moves.
  const double scale = 1.0 + fx.speed_scale_pct / 100.0;
  const double speed_abs = std::fabs(st.v);
  const bool standing = speed_abs < 0.01;
  const double sensed_speed = Delayed(sensed_speed_, speed_abs, fx.speed_delay_ms / 1000.0);
  out.speed_meas_mps.push_back(sensed_speed < 0.01 ? 0.0
                                                   : std::max(0.0, scale * sensed_speed + fx.speed_offset_kph / 3.6 +
                                                                       nz.speed_kph / 3.6 * n_speed));
  const double half_track = 0.5 * cfg_.vehicle.track_width_m;
  const double sgn = st.v < 0 ? -1.0 : 1.0;
  for (int w = 0; w < 4; ++w) {
    const double side = (w % 2 == 0) ? -1.0 : 1.0;  // left wheels (FL, RL) on the inside of a left turn
    // Rolling radius: the outer wheels (right in a left turn, a_y > 0) carry more load and roll
    // on a smaller radius, so they turn (and read) faster; the rear right's radius differs by d.
    const double load = 1.0 + side * fx.wheel_radius_load_pct_per_g / 100.0 * st.a_y / g;
    const double radius = w == 3 ? 1.0 / (1.0 + fx.rear_wheel_radius_diff_pct / 100.0) : 1.0;
    const double vw = std::fabs(st.v + sgn * side * st.r * half_track) * load * radius;
    out.wheel_speed_meas_mps[w].push_back(standing ? 0.0 : std::max(0.0, scale * vw + nz.speed_kph / 3.6 * n_wheel[w]));
  }

  // Accelerometer: a_y,meas = a_y + g*phi + x_s*r' + b + disturbance + noise.
  // Accelerometer scale (1 + k_a) on the CG acceleration (as the model's accel_scale).
  // Latency: the sensed acceleration reaches the bus accel_delay_ms later (an exact delay).
  // Nonlinearity (even, second order) on everything the element senses: q + k2 q^2/g.
  const double q = (1.0 + fx.accel_scale_pct / 100.0) * st.a_y + g * st.roll + fx.lever_arm_m * st.r_dot;
  const double sensed_a_y = Delayed(sensed_a_y_, q + fx.accel_quadratic_pct / 100.0 * q * q / g, fx.accel_delay_ms / 1000.0);
  // Vibration while moving (a raw IMU on a stiff mount), rising to its RMS by 5 m/s.
  const double shaking = std::min(1.0, speed_abs / 5.0);
  const double vib_a = fx.accel_vibration_mps2 > 0 ? fx.accel_vibration_mps2 * shaking * Vibration(accel_tones_, st.t) : 0.0;
  const double vib_r = fx.gyro_vibration_degps > 0 ? fx.gyro_vibration_degps * kDeg * shaking * Vibration(gyro_tones_, st.t) : 0.0;
  out.a_y_meas_mps2.push_back(sensed_a_y + fx.accel_bias_mps2 + disturbance + nz.lat_accel_mps2 * n_ay + vib_a);
  out.a_x_meas_mps2.push_back(st.a_x + nz.long_accel_mps2 * n_ax);
  // Gyro: r_meas = (1 + k_r) r + r0 + noise.
  // Latency: the yaw rate reaches the bus gyro_delay_ms later (an exact delay).
  const double sensed_r = Delayed(sensed_r_, st.r, fx.gyro_delay_ms / 1000.0);
  out.yaw_rate_meas_radps.push_back((1.0 + fx.gyro_scale_pct / 100.0) * sensed_r + fx.gyro_offset_degps * kDeg +
                                    nz.yaw_rate_degps * kDeg * n_r + vib_r);

  out.valid.push_back(st.t >= kValidAfter_s ? 1 : 0);
  out.esp_active.push_back((std::fabs(st.a_y) > 0.8 * mu_esp_ * g || std::fabs(st.beta) > 4.0 * kDeg) ? 1 : 0);
  out.brake.push_back((st.a_x < -0.3 || standing) ? 1 : 0);
  out.gear.push_back(gear);
}

}  // namespace ndsid::sim
