// `ndsid simulate` as a library: naturalistic drives (key cycles) of a car with known true
// parameters and switchable hidden effects, as 100 Hz time series of the true and the measured
// signals. The CAN log (candump_writer.h) and the truth file (truth_writer.h) are written from
// these, so tests and estimator tests can use the series directly.
#pragma once

#include <cstdint>
#include <functional>
#include <string>
#include <vector>

#include "ndsid/config/simulation_config.h"
#include "ndsid/model/single_track.h"
#include "ndsid/sim/driver.h"

namespace ndsid::sim {

inline constexpr double kOutputRate_hz = 100.0;

// 100 Hz samples of one drive, struct of arrays, SI units, ISO 8855 signs.
struct DriveSeries {
  std::vector<double> t_s;                 // since key-on
  // truth
  std::vector<double> steer_sw_rad;        // steering-wheel angle
  std::vector<double> speed_mps;           // signed (negative when reversing)
  std::vector<double> a_y_mps2;            // tyre forces / m at the CG (incl. bank support)
  std::vector<double> yaw_rate_radps;
  std::vector<double> yaw_accel_radps2;    // r' (the lever-arm term)
  std::vector<double> side_slip_rad;       // beta
  std::vector<double> a_x_mps2;            // v'
  std::vector<double> roll_rad;            // body roll rel. to road (0 unless the roll effect is on)
  std::vector<double> bank_rad;            // road ISO roll angle (crossfall + superelevation)
  std::vector<double> curvature_1pm;       // road (lane centre) curvature at the car
  std::vector<double> s_m;                 // distance along the road
  std::vector<double> lateral_offset_m;    // e_y from the reference lane centre
  std::vector<double> lane_target_m;       // the driver's target e_y (lane changes, evasive manoeuvres)
  std::vector<double> heading_error_rad;   // psi_e relative to the road
  std::vector<uint8_t> reverse;            // reverse gear engaged
  // measured (before DBC quantisation)
  std::vector<double> steer_sw_meas_rad;
  std::vector<double> steer_rate_meas_radps;
  std::vector<double> speed_meas_mps;      // >= 0
  std::vector<double> a_y_meas_mps2;
  std::vector<double> yaw_rate_meas_radps;
  std::vector<double> a_x_meas_mps2;
  std::vector<double> wheel_speed_meas_mps[4];  // FL, FR, RL, RR
  std::vector<uint8_t> valid;              // SteeringAngleValid / DynamicsValid
  std::vector<uint8_t> esp_active;         // EspIntervention
  std::vector<uint8_t> brake;              // BrakeSwitch
  std::vector<uint8_t> gear;               // 0 P, 1 R, 3 D

  size_t size() const { return t_s.size(); }
  void Reserve(size_t n);
};

struct DriveStats {
  double distance_km = 0.0;
  double duration_s = 0.0;
  double moving_s = 0.0;             // |v| > 1 m/s
  double mean_speed_kph = 0.0;       // distance / moving time
  double abs_ay_q50 = 0, abs_ay_q75 = 0, abs_ay_q90 = 0, abs_ay_q99 = 0, abs_ay_max = 0;  // measured, moving
  double frac_ay_below_1 = 0, frac_ay_below_2 = 0, frac_ay_below_5 = 0;
  double gated_fraction = 0.0;       // samples passing physics.md §2's gate (v > 5 m/s, |a_y| < 4, fwd, valid)
  double standstill_s = 0.0;
  int stops = 0;
  int evasive = 0;
  double urban_km = 0, rural_km = 0, motorway_km = 0;
};

struct DriveResult {
  int index = 0;
  int64_t start_epoch_ns = 0;
  int driver = 0;
  model::Params<double> params{};    // true parameters of this drive (mass change applies)
  double self_steer_gradient = 0.0;  // EG [rad/(m/s^2)] of this drive
  double gyro_offset_degps = 0.0;    // the yaw-rate sensor's offset on this drive (r0 + per-drive part)
  double ambient_temp_c = 15.0;
  double odometer_start_km = 0.0;
  DriveSeries series;
  DriveStats stats;
};

struct SimulationResult {
  config::SimulationConfig config;
  std::vector<DriverProfile> drivers;
  std::vector<DriveResult> drives;
};

// Simulates every drive and keeps them (memory ~ 0.3 GB per 10 h; use SimulateDrives for long runs).
SimulationResult Simulate(const config::SimulationConfig& config);

// Streams the drives one by one (the same drives as Simulate). Returns the driver population.
std::vector<DriverProfile> SimulateDrives(const config::SimulationConfig& config,
                                          const std::function<void(DriveResult&&)>& sink);

// Statistics of a finished drive (also filled by the simulator).
DriveStats ComputeDriveStats(const DriveSeries& series);

// True base parameters from the config (before any per-drive mass change).
model::Params<double> BaseParams(const config::SimVehicle& vehicle);

}  // namespace ndsid::sim
