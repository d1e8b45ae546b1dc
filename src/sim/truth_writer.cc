#include "ndsid/sim/truth_writer.h"

#include <cmath>
#include <sstream>

#include "ndsid/common/error.h"

namespace ndsid::sim {

namespace {
constexpr double kDeg = 180.0 / M_PI;

std::string Quote(const std::string& s) {
  std::string out = "\"";
  for (char c : s) {
    if (c == '"' || c == '\\') out += '\\';
    out += c;
  }
  return out + "\"";
}

std::string Num(double x, int digits = 6) {
  std::ostringstream o;
  o.precision(digits);
  o << x;
  return o.str();
}
}  // namespace

void TruthSummary::Add(const DriveResult& d) {
  drives_.push_back({d.index, d.start_epoch_ns, d.driver, d.params, d.self_steer_gradient, d.stats, d.gyro_offset_degps});
  const auto& s = d.series;
  for (size_t i = 0; i < s.size(); ++i) {
    if (std::fabs(s.speed_mps[i]) <= 1.0) continue;
    const size_t bin = std::min(histogram_.size() - 1, static_cast<size_t>(std::fabs(s.a_y_meas_mps2[i]) / kBin_mps2));
    ++histogram_[bin];
    ++moving_;
  }
  samples_ += s.size();
  gated_ += static_cast<uint64_t>(std::llround(d.stats.gated_fraction * static_cast<double>(s.size())));
}

double TruthSummary::hours() const {
  double h = 0;
  for (const auto& d : drives_) h += d.stats.duration_s / 3600.0;
  return h;
}
double TruthSummary::km() const {
  double k = 0;
  for (const auto& d : drives_) k += d.stats.distance_km;
  return k;
}
double TruthSummary::AbsLatAccelQuantile(double p) const {
  const auto target = static_cast<uint64_t>(p * static_cast<double>(moving_));
  uint64_t cum = 0;
  for (size_t i = 0; i < histogram_.size(); ++i) {
    cum += histogram_[i];
    if (cum > target) return (static_cast<double>(i) + 1.0) * kBin_mps2;  // upper edge of the bin
  }
  return static_cast<double>(histogram_.size()) * kBin_mps2;
}
double TruthSummary::FractionBelow(double a) const {
  uint64_t cum = 0;
  const auto bins = static_cast<size_t>(std::llround(a / kBin_mps2));
  for (size_t i = 0; i < std::min(bins, histogram_.size()); ++i) cum += histogram_[i];
  return moving_ ? static_cast<double>(cum) / static_cast<double>(moving_) : 0.0;
}
double TruthSummary::GatedFraction() const {
  return samples_ ? static_cast<double>(gated_) / static_cast<double>(samples_) : 0.0;
}

std::string TruthYaml(const config::SimulationConfig& c, const std::vector<DriverProfile>& drivers,
                      const TruthSummary& summary, const std::vector<std::pair<std::string, std::string>>& files) {
  std::ostringstream y;
  const auto p = BaseParams(c.vehicle);
  const double l = c.vehicle.wheelbase_m;
  const double eg = model::SelfSteerGradient(p, l);
  y << "# Truth of an `ndsid simulate` run: what the estimator should find. SI units unless the key\n"
       "# says otherwise; signs ISO 8855 (+ left). Written by the simulator, see docs/simulator.md.\n";
  y << "generator: \"ndsid simulate 0.1.0\"\n";
  y << "command_line: " << Quote(c.command_line) << "\n";
  y << "config_file: " << Quote(c.source_file) << "\n";
  y << "seed: " << c.seed << "\n";
  y << "start_epoch_s: " << c.start_epoch_s << "\n";
  y << "files:\n";
  for (const auto& [name, path] : files) y << "  " << name << ": " << Quote(path) << "\n";
  y << "vehicle:  # base parameters (mass_change effects: see drives[].mass_kg)\n";
  y << "  mass_kg: " << Num(p.m) << "\n";
  y << "  yaw_inertia_kgm2: " << Num(p.Jz) << "\n";
  y << "  cornering_stiffness_front_npr: " << Num(p.cv) << "\n";
  y << "  cornering_stiffness_rear_npr: " << Num(p.ch) << "\n";
  y << "  cg_to_front_m: " << Num(p.lv) << "\n";
  y << "  cg_to_rear_m: " << Num(l - p.lv) << "\n";
  y << "  wheelbase_m: " << Num(l) << "\n";
  y << "  steering_ratio: " << Num(p.is) << "\n";
  y << "  track_width_m: " << Num(c.vehicle.track_width_m) << "\n";
  y << "  self_steer_gradient_rad_per_mps2: " << Num(eg, 8) << "  # EG = m/l (lh ch - lv cv)/(cv ch)\n";
  y << "  self_steer_gradient_deg_per_g: " << Num(model::EgToDegPerG(eg), 8) << "\n";
  if (eg > 0) y << "  characteristic_speed_kph: " << Num(std::sqrt(l / eg) * 3.6) << "\n";
  y << "  identifiable_ratios: {cv_over_m: " << Num(p.cv / p.m) << ", ch_over_m: " << Num(p.ch / p.m)
    << ", jz_over_m: " << Num(p.Jz / p.m) << "}\n";
  y << "effects:  # value 0 (tyre_mu 0) = off\n";
  for (const auto& e : config::EffectTable()) {
    const double v = c.effects.*e.field;
    const bool param = std::string(e.name) == "roll_frequency_hz" || std::string(e.name) == "roll_damping_ratio";
    const bool on = param ? c.effects.roll_on() : v != 0.0;
    y << "  " << e.name << ": {value: " << Num(v) << ", enabled: " << (on ? "true" : "false") << ", unit: \""
      << e.unit << "\", meaning: " << Quote(e.meaning) << "}\n";
  }
  y << "  mass_schedule_kg: [";
  for (size_t i = 0; i < c.effects.mass_schedule_kg.size(); ++i) y << (i ? ", " : "") << Num(c.effects.mass_schedule_kg[i]);
  y << "]\n";
  y << "noise:  # white-noise standard deviations, before the DBC quantisation\n";
  y << "  steer_deg: " << Num(c.noise.steer_deg) << "\n  speed_kph: " << Num(c.noise.speed_kph)
    << "\n  lat_accel_mps2: " << Num(c.noise.lat_accel_mps2) << "\n  long_accel_mps2: " << Num(c.noise.long_accel_mps2)
    << "\n  yaw_rate_degps: " << Num(c.noise.yaw_rate_degps)
    << "\n  lat_accel_disturbance_mps2: " << Num(c.noise.lat_accel_disturbance_mps2)
    << "  # Ornstein-Uhlenbeck, zero mean\n  lat_accel_disturbance_tau_s: " << Num(c.noise.lat_accel_disturbance_tau_s)
    << "\n";
  y << "road:\n  crossfall_pct_max: " << Num(c.road.crossfall_pct_max)
    << "  # zero-mean random crossfall, shows at standstill as a_y = g sin(theta)\n  crossfall_correlation_m: "
    << Num(c.road.crossfall_correlation_m) << "\n  evasive_per_hour: " << Num(c.road.evasive_per_hour) << "\n";
  y << "integration: {method: rk4, step_hz: " << Num(c.integration.step_hz)
    << ", kinematic_below_mps: " << Num(c.integration.kinematic_below_mps)
    << ", dynamic_above_mps: " << Num(c.integration.dynamic_above_mps) << ", output_hz: 100}\n";
  y << "signals:  # roles for config/example_vehicle.yaml (dbc/ndsid_example.dbc)\n"
       "  steering: STEERING_SENSOR.SteeringWheelAngle  # deg, + left\n"
       "  speed: VEHICLE_SPEED.VehicleSpeed  # km/h\n"
       "  lateral_accel: ESP_DYNAMICS.LateralAcceleration  # m/s^2, + left\n"
       "  yaw_rate: ESP_DYNAMICS.YawRate  # deg/s, + left\n"
       "  long_accel: ESP_DYNAMICS.LongitudinalAcceleration  # m/s^2\n"
       "  reverse: VEHICLE_STATUS.ReverseGear\n"
       "  steering_valid: STEERING_SENSOR.SteeringAngleValid\n"
       "  dynamics_valid: ESP_DYNAMICS.DynamicsValid\n"
       "  esc_intervention: ESP_DYNAMICS.EspIntervention\n";
  y << "drivers:\n";
  for (const auto& d : drivers) {
    y << "  - {id: " << d.id << ", speed_factor: " << Num(d.speed_factor, 4)
      << ", lat_accel_comfort_mps2: " << Num(d.lat_accel_comfort_mps2, 4) << ", accel_mps2: " << Num(d.accel_mps2, 4)
      << ", decel_mps2: " << Num(d.decel_mps2, 4) << ", preview_s: " << Num(d.preview_s, 4)
      << ", lookahead_s: " << Num(d.lookahead_s, 4) << ", neuromuscular_tau_s: " << Num(d.neuromuscular_tau_s, 4)
      << ", steer_noise_deg: " << Num(d.steer_noise_rad * kDeg, 4)
      << ", belief_eg_factor: " << Num(d.belief_eg_factor, 5) << ", belief_is_factor: " << Num(d.belief_is_factor, 5)
      << "}\n";
  }
  y << "totals:\n";
  int long_drives = 0;
  for (const auto& d : summary.drives()) long_drives += d.stats.distance_km >= 2.0;
  y << "  drives: " << summary.drives().size() << "\n  drives_at_least_2km: " << long_drives
    << "\n  hours: " << Num(summary.hours()) << "\n  km: " << Num(summary.km())
    << "\n  gated_fraction: " << Num(summary.GatedFraction(), 4) << "\n";
  y << "  abs_lat_accel_moving:  # |a_y,meas| with |v| > 1 m/s (study: 75 % < 1, > 90 % < 2, > 99 % < 5 m/s^2)\n";
  y << "    q50_mps2: " << Num(summary.AbsLatAccelQuantile(0.5), 4) << "\n    q75_mps2: "
    << Num(summary.AbsLatAccelQuantile(0.75), 4) << "\n    q90_mps2: " << Num(summary.AbsLatAccelQuantile(0.9), 4)
    << "\n    q99_mps2: " << Num(summary.AbsLatAccelQuantile(0.99), 4)
    << "\n    fraction_below_1_mps2: " << Num(summary.FractionBelow(1.0), 4)
    << "\n    fraction_below_2_mps2: " << Num(summary.FractionBelow(2.0), 4)
    << "\n    fraction_below_5_mps2: " << Num(summary.FractionBelow(5.0), 4) << "\n";
  y << "drives:\n";
  for (const auto& d : summary.drives()) {
    const auto& s = d.stats;
    const double start = static_cast<double>(d.start_epoch_ns) / 1e9;
    y << "  - index: " << d.index << "\n";
    y << "    start_epoch_s: " << Num(start, 16) << "\n    end_epoch_s: " << Num(start + s.duration_s, 16) << "\n";
    y << "    driver: " << d.driver << "\n    mass_kg: " << Num(d.params.m) << "\n    yaw_inertia_kgm2: "
      << Num(d.params.Jz) << "\n";
    if (c.effects.gyro_offset_drive_degps > 0) y << "    gyro_offset_degps: " << Num(d.gyro_offset_degps, 6) << "\n";
    y << "    self_steer_gradient_rad_per_mps2: " << Num(d.self_steer_gradient, 8)
      << "\n    self_steer_gradient_deg_per_g: " << Num(model::EgToDegPerG(d.self_steer_gradient), 8) << "\n";
    y << "    distance_km: " << Num(s.distance_km, 5) << "\n    duration_s: " << Num(s.duration_s, 6)
      << "\n    moving_s: " << Num(s.moving_s, 6) << "\n    standstill_s: " << Num(s.standstill_s, 6)
      << "\n    mean_speed_kph: " << Num(s.mean_speed_kph, 4) << "\n";
    y << "    km_by_road: {urban: " << Num(s.urban_km, 4) << ", rural: " << Num(s.rural_km, 4)
      << ", motorway: " << Num(s.motorway_km, 4) << "}\n";
    y << "    stops: " << s.stops << "\n    evasive_manoeuvres: " << s.evasive << "\n";
    y << "    abs_lat_accel_moving: {q50: " << Num(s.abs_ay_q50, 4) << ", q75: " << Num(s.abs_ay_q75, 4)
      << ", q90: " << Num(s.abs_ay_q90, 4) << ", q99: " << Num(s.abs_ay_q99, 4) << ", max: " << Num(s.abs_ay_max, 4)
      << ", below_1: " << Num(s.frac_ay_below_1, 4) << ", below_2: " << Num(s.frac_ay_below_2, 4)
      << ", below_5: " << Num(s.frac_ay_below_5, 4) << "}\n";
    y << "    gated_fraction: " << Num(s.gated_fraction, 4) << "  # v > 5 m/s, |a_y| < 4, forward, valid, no ESC\n";
  }
  return y.str();
}

SignalsCsvWriter::SignalsCsvWriter(const std::string& path) : path_(path), file_(std::fopen(path.c_str(), "wb")) {
  if (!file_) throw Error(path + ": cannot open for writing");
  std::fputs(
      "drive,t_s,epoch_s,steer_sw_deg,steer_sw_meas_deg,speed_kph,speed_meas_kph,a_y_mps2,a_y_meas_mps2,"
      "yaw_rate_degps,yaw_rate_meas_degps,a_x_mps2,a_x_meas_mps2,yaw_accel_radps2,side_slip_deg,roll_deg,bank_deg,"
      "curvature_1pm,s_m,lateral_offset_m,heading_error_deg,reverse,valid,esp_active\n",
      file_);
}

SignalsCsvWriter::~SignalsCsvWriter() {
  if (file_) std::fclose(file_);
}

void SignalsCsvWriter::WriteDrive(const DriveResult& d) {
  const auto& s = d.series;
  const double t0 = static_cast<double>(d.start_epoch_ns) / 1e9;
  for (size_t i = 0; i < s.size(); ++i) {
    std::fprintf(file_,
                 "%d,%.2f,%.2f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.6f,%.7f,%.3f,%.4f,%.5f,"
                 "%d,%d,%d\n",
                 d.index, s.t_s[i], t0 + s.t_s[i], s.steer_sw_rad[i] * kDeg, s.steer_sw_meas_rad[i] * kDeg,
                 s.speed_mps[i] * 3.6, s.speed_meas_mps[i] * 3.6, s.a_y_mps2[i], s.a_y_meas_mps2[i],
                 s.yaw_rate_radps[i] * kDeg, s.yaw_rate_meas_radps[i] * kDeg, s.a_x_mps2[i], s.a_x_meas_mps2[i],
                 s.yaw_accel_radps2[i], s.side_slip_rad[i] * kDeg, s.roll_rad[i] * kDeg, s.bank_rad[i] * kDeg,
                 s.curvature_1pm[i], s.s_m[i], s.lateral_offset_m[i], s.heading_error_rad[i] * kDeg, s.reverse[i],
                 s.valid[i], s.esp_active[i]);
  }
}

void SignalsCsvWriter::Close() {
  if (file_ && std::fclose(file_) != 0) {
    file_ = nullptr;
    throw Error(path_ + ": write failed");
  }
  file_ = nullptr;
}

}  // namespace ndsid::sim
