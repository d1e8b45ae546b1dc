// Configuration of `ndsid simulate` (config/sim_*.yaml): the true vehicle, the drives, the
// driver population, the sensors and the hidden effects. Plain values, SI inside; the YAML keys
// carry their units (documented in config/sim_cmax.yaml and docs/simulator.md).
#pragma once

#include <cstdint>
#include <map>
#include <string>
#include <string_view>
#include <vector>

namespace ndsid::config {

// Hidden effects the base single-track model leaves out (physics.md §4). Each is off at its
// neutral value (0, or tyre_mu = 0 meaning linear tyres). Magnitudes in the units of the name.
struct SimEffects {
  double accel_bias_mps2 = 0.0;          // a_y,meas = a_y + b
  double steer_offset_deg = 0.0;         // d_sw,meas = d_sw,true + d0 (at the steering wheel)
  double roll_gradient_deg_per_g = 0.0;  // phi_ss = k_phi * a_y ; a_y,meas = a_y + g*phi
  double roll_frequency_hz = 1.5;        // undamped roll eigenfrequency (used when roll is on)
  double roll_damping_ratio = 0.5;       // roll damping ratio (used when roll is on)
  double superelevation_pct = 0.0;       // max bank into curves, |tan(theta)| * 100
  double lever_arm_m = 0.0;              // accelerometer ahead of the CG: a_y,meas = a_y + x_s*r'
  double tyre_mu = 0.0;                  // 0: linear tyres; else F = D*tanh(c*alpha/D), D = mu*Fz
  double rear_stiffness_speed_pct = 0.0;  // ch(v) = ch (1 + k (v/30 m/s)^2), k * 100 (not in the model library)
  double steer_deadband_deg = 0.0;       // on-centre free play at the wheel: the road wheels see d_sw - clip(d_sw, -b, b) (not in the model library)
  double steer_asymmetry_pct = 0.0;      // the road wheels see d_sw (1 + k sgn d_sw), k * 100: left/right unequal (not in the model library)
  double rear_steer_pct = 0.0;           // active rear steering: delta_h = k ((v/30)^2 - 1/4) delta, k * 100 (not in the model library)
  double relaxation_length_m = 0.0;      // slip-angle lag alpha_l' = (alpha - alpha_l) * v/sigma
  double steer_delay_ms = 0.0;           // the steering message carries d_sw(t - dt)
  double speed_scale_pct = 0.0;          // v_meas = (1 + eps) * v (wheel speeds and odometer too)
  double speed_offset_kph = 0.0;         // vehicle speed signal only: v_meas = (1 + eps) * v + c while moving
  double speed_delay_ms = 0.0;           // vehicle speed signal latency: v_meas(t) from v(t - tau)
  double gyro_offset_degps = 0.0;        // yaw-rate sensor: r_meas = (1 + k_r) r + r0, r0 here
  double gyro_offset_drive_degps = 0.0;  // per drive: r0_i = r0 + U(-d, +d) (re-zeroed at every ignition)
  double gyro_scale_pct = 0.0;           // k_r * 100
  double accel_scale_pct = 0.0;          // accelerometer: a_y,meas = (1 + k_a) a_y + ..., k_a * 100
  double accel_quadratic_pct = 0.0;      // accelerometer nonlinearity: a_y,meas = q + k2 q^2/g, k2 * 100 (not in the model library)
  double gyro_delay_ms = 0.0;            // yaw-rate sensor latency: r_meas(t) = r(t - tau)
  double accel_delay_ms = 0.0;           // accelerometer latency: a_y,meas(t) = a_y,sensed(t - tau)
  double mass_change_kg = 0.0;           // per drive: m_i = m + U(-dm, +dm) (Jz scaled with m_i/m)
  double accel_vibration_mps2 = 0.0;     // RMS of a 15..35 Hz vibration on the accelerometer while moving
  double gyro_vibration_degps = 0.0;     // RMS of a 15..35 Hz vibration on the gyro while moving
  double rear_wheel_radius_diff_pct = 0.0;  // rear right tyre's rolling radius above the left's: RR reads v/(1 + d)
  double wheel_radius_load_pct_per_g = 0.0;  // rolling radius falling with lateral load: outer wheels read (1 + c a_y/g)
  std::vector<double> mass_schedule_kg;  // if non-empty: m_i = m + schedule[i % size] (overrides)

  bool roll_on() const { return roll_gradient_deg_per_g != 0.0; }
  bool any() const;
};

// One entry of the effect table: command-line / YAML name, unit, meaning, typical range.
struct EffectInfo {
  const char* name;
  const char* unit;
  const char* meaning;
  const char* typical;
  double SimEffects::*field;
};
const std::vector<EffectInfo>& EffectTable();

// Applies "name=value" (e.g. "steer_offset_deg=1.5"). Throws ConfigError naming the text and
// the known names when the name is unknown or the value not a finite number.
void ApplyEffect(SimEffects& effects, std::string_view assignment);

// The true vehicle: base single-track parameters plus geometry used by the sensors.
struct SimVehicle {
  double mass_kg = 1900.0;                    // m
  double yaw_inertia_kgm2 = 2700.0;           // Jz
  double cornering_stiffness_front_npr = 75000.0;   // cv [N/rad]
  double cornering_stiffness_rear_npr = 120000.0;   // ch [N/rad]
  double cg_to_front_m = 1.15;                // lv
  double wheelbase_m = 2.648;                 // l
  double steering_ratio = 14.8;               // is
  double track_width_m = 1.55;                // wheel-speed sensors left/right
};

// White noise (standard deviations) and a slow bias-free disturbance on the accelerometer.
struct SimNoise {
  double steer_deg = 0.1;
  double speed_kph = 0.05;
  double lat_accel_mps2 = 0.05;
  double long_accel_mps2 = 0.05;
  double yaw_rate_degps = 0.1;
  double lat_accel_disturbance_mps2 = 0.02;   // Ornstein-Uhlenbeck, zero mean
  double lat_accel_disturbance_tau_s = 2.0;
};

// Road generation.
struct SimRoad {
  double crossfall_pct_max = 3.0;        // |crossfall| clipped here; random, zero mean
  double crossfall_correlation_m = 400.0;
  double evasive_per_hour = 1.0;         // rare evasive double lane changes
  int parking_turns = 0;                 // tight turns at walking pace at each end of every drive
};

// Driver population; each drive picks one driver, each driver draws its parameters once.
struct SimDrivers {
  int count = 3;
  double lat_accel_comfort_min_mps2 = 2.2;   // per-driver comfortable |a_y| in curves
  double lat_accel_comfort_max_mps2 = 3.8;
  double belief_error_pct = 4.0;             // |error| of the driver's internal EG and is
  double steer_noise_deg = 1.0;              // correction noise at the steering wheel (per driver +-40 %)
};

struct SimDuration {
  double hours = 1.0;  // drive until the driving time reaches this (if drives == 0)
  int drives = 0;      // if > 0: exactly this many drives
  double short_drive_fraction = 0.12;  // drives < 2 km (parking / short trips)
  double min_km = 2.0;                 // range of the normal drives' length (log-uniform)
  double max_km = 60.0;
  double gap_min_h = 0.5;              // key-off gap between drives (no frames)
  double gap_max_h = 14.0;
};

struct SimIntegration {
  double step_hz = 200.0;            // RK4 step of the vehicle truth
  double kinematic_below_mps = 1.0;  // pure kinematic model below (blend up to dynamic_above_mps)
  double dynamic_above_mps = 3.0;    // pure single-track model above
};

// `bus:` encode the simulated quantities into another DBC's signals (an OEM or opendbc file),
// docs/simulator.md. Empty `signals`: the example DBC's signal names decide (the default).
struct SimBus {
  // Messages without a GenMsgCycleTime are sent at this cycle [ms] (0: not sent) ...
  double default_cycle_ms = 0;
  // ... except those carrying a mapped signal, sent at this cycle [ms] (10..10000).
  double signal_cycle_ms = 10;
  // Message name -> its cycle [ms] (10..10000), over the DBC's GenMsgCycleTime and the two above:
  // a sensor sent at a low rate (a 10 Hz gyro). Rounded to the 10 ms tick.
  std::map<std::string, double> message_cycle_ms;
  // Each frame lost with this probability [%] (0..50; a stream of its own, so 0 keeps the log
  // bit-identical): irregular sample intervals, as a logger or gateway that drops frames gives.
  // The ECU's rolling counter still advances over a lost frame.
  double frame_loss_pct = 0;
  // Quantity -> "MESSAGE.SIGNAL"; the quantities are listed in SimBusQuantities(). Each value is
  // written in the signal's DBC unit when that is one of deg|rad, deg/s|rad/s, km/h|m/s|mph,
  // m/s^2|g (else in the quantity's own unit: deg, deg/s, km/h, m/s^2). Every other signal of the
  // DBC is sent as 0 (counters count, checksums XOR).
  std::map<std::string, std::string> signals;
};
// The quantity names `bus.signals` accepts.
const std::vector<std::string>& SimBusQuantities();

struct SimulationConfig {
  uint64_t seed = 1;
  SimVehicle vehicle;
  SimDuration duration;
  SimIntegration integration;
  SimRoad road;
  SimDrivers drivers;
  SimNoise noise;
  SimEffects effects;
  int64_t start_epoch_s = 1709537400;  // 2024-03-04 07:30:00 UTC, first drive's key-on
  std::string bus_name = "can0";
  SimBus bus;
  std::string source_file;             // YAML it was loaded from ("" = defaults)
  std::string command_line;            // recorded in the truth file
};

// Loads a YAML file; every key is optional (defaults above), unknown keys are errors. Throws
// ConfigError "file:line:column: message" naming the key path.
SimulationConfig LoadSimulationConfig(const std::string& path);
SimulationConfig ParseSimulationConfig(std::string_view yaml_text, const std::string& file_name_for_messages);

// Checks ranges (positive masses, step >= 100 Hz, 0 <= mu ...). Throws ConfigError.
void ValidateSimulationConfig(const SimulationConfig& config);

}  // namespace ndsid::config
