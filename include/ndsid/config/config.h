// The per-vehicle configuration: one YAML file (see config/example_vehicle.yaml for every key
// with meaning, unit, default and range). Loaded and validated once at start-up; the stages
// receive the plain structs below. Units are SI; role signals carry their bus unit and sign so
// conversion happens at the edge (RoleSignal::ToSi).
#pragma once

#include <array>
#include <string>
#include <vector>
#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ndsid/common/error.h"
#include "ndsid/common/expression.h"

namespace ndsid::config {

// What the estimator needs from the bus. Required: steering-wheel angle, speed, lateral accel.
enum class Role {
  kSteeringWheelAngle = 0,  // rad, + left
  kSpeed,                   // m/s
  kLateralAcceleration,     // m/s^2, + left (ISO 8855)
  kYawRate,                 // rad/s, + left (optional)
  kLongitudinalAcceleration,// m/s^2, + forward (optional)
  kReverseGear,             // flag (optional)
  kEscIntervention,         // flag (optional)
  kWheelSpeed,              // m/s, the wheel speeds' mean (optional; a role expression): plausibility
  kRearWheelSpeedDifference,// m/s, rear right minus rear left wheel speed (optional; a role expression):
                            // with vehicle.track_rear_m, a yaw-rate reference (stats/wheel_yaw.h)
  kCount
};
inline constexpr int kNumRoles = static_cast<int>(Role::kCount);
const char* RoleKey(Role role);  // YAML key, e.g. "steering_wheel_angle"
bool RoleIsRequired(Role role);
bool RoleIsFlag(Role role);

struct SignalRef {
  std::string message;
  std::string signal;
};

struct RoleSignal {
  SignalRef ref;          // the signal; for a role expression its first input
  // A role computed from several signals (docs/configuration.md, "Role expressions"): the text,
  // its inputs in the order of the expression's variables, and the parsed expression, evaluated
  // on the inputs' physical values before unit and sign. Empty for a single-signal role.
  std::string expr;
  std::vector<SignalRef> inputs;
  std::shared_ptr<const Expression> expression;
  std::string unit;       // unit on the bus: deg|rad, km/h|m/s|mph, m/s^2|g, deg/s|rad/s, "" for flags
  double scale_to_si = 1; // sign * unit conversion, so value_si = raw_physical * scale_to_si
  double timeout_s = 0.1; // a value older than this is stale
  // Time alignment (physics.md §5 step 0): the value is stamped this long after the instant it
  // describes, relative to the lateral acceleration; the sync stage reads it at t - latency_s.
  double latency_s = 0;
  // Conditioning (sync/lowpass.h): a causal Bessel low-pass at this -3 dB frequency on the sync
  // grid, its delay taken back by the sync stage; 0: none.
  double lowpass_hz = 0;
  std::vector<double> active_values;  // flags: physical values meaning "active" (default {1})
  int line = 0;           // YAML line, for messages

  double ToSi(double physical) const { return physical * scale_to_si; }
  bool IsActive(double physical) const;
};

// A validity flag: the sample is invalid unless the signal equals one of `valid_values`.
struct ValiditySignal {
  SignalRef ref;
  std::vector<double> valid_values{1.0};
  double timeout_s = 0.2;
  int line = 0;
};

struct SourceConfig {
  enum class Type { kLog, kSocketCan } type = Type::kLog;
  std::vector<std::string> logs;  // candump -l files (plain or .gz), resolved against the config dir
  std::string interface;          // SocketCAN interface, e.g. "can0"
  std::string bus;                // in a multi-bus log, the bus to use ("" = all)
  bool realtime = false;          // replay at recorded speed
};

struct SyncConfig {
  double rate_hz = 100.0;        // fixed output rate of synchronised samples
  double latency_s = 0.05;       // how long to wait for late messages before emitting a sample
  double max_fill_gap_s = 1.0;   // a bus silence longer than this is not filled with samples
};

struct GateConfig {
  double min_speed_mps = 5.0;            // model singular at v -> 0
  double standstill_speed_mps = 0.1;
  double standstill_min_s = 1.0;
  double max_abs_lat_accel_mps2 = 4.0;   // linear range of the single-track model
  double drive_gap_s = 60.0;             // bus silence that ends a key cycle
  double min_drive_km = 2.0;             // the study's rule
  double min_segment_s = 4.0;            // shortest contiguous gated stretch for the dynamic fit
  double quasi_steady_max_steer_rate_radps = 0.05;  // |d_sw'| for the steady-state statistics
  // A road-wheel angle (vehicle.steering_angle_at: road_wheels) divides the default by this.
  static constexpr double kTypicalSteerRatio = 15;
  double quasi_steady_max_yaw_accel_radps2 = 0.02;
};

// Box, initial value and whether each of p = (m, Jz, cv, ch, lv, is) is fixed.
struct ParameterSpec {
  double lower = 0, upper = 0, initial = 0;
  bool fixed = false;
};

// model.priors' name of a prior on the self-steering gradient itself (value and sd in deg/g).
inline constexpr const char* kEgPriorName = "eg_deg_per_g";
// model.alternatives: at most this many (each is one more fit of the window per estimate).
inline constexpr size_t kMaxAlternatives = 8;
// model.watch: at most this many (each is one score test per estimate, and a fit when significant).
inline constexpr size_t kMaxWatched = 8;

// A Gaussian prior on one model parameter (model.priors in the YAML): a data-sheet roll
// gradient, a measured tyre radius... Enters the fit as a residual (p - value)/sd weighted by
// the data's noise level, and the covariance as information.
struct ParameterPrior {
  std::string name;  // a base or effect parameter name, e.g. "roll_gradient_rad_per_mps2"
  double value = 0;
  double sd = 0;
  std::string location;  // file:line, for errors found after loading (unknown parameter)
};

struct IdentificationConfig {
  std::array<ParameterSpec, 6> params;  // order of ndsid::model::ParamIndex
  std::vector<ParameterPrior> priors;   // from model.priors; applied when the model has the parameter
  // identification.prior_from: a fleet prior (a group's fleet_prior.yaml of `ndsid fleet`, or its
  // fleet.parquet with prior_group; docs/fleet.md) whose parameters join `priors` where
  // model.priors does not name them; resolved path, "" = none.
  std::string prior_from;
  std::string prior_group;  // identification.prior_group: the group of the fleet table's prior
  double rate_hz = 50.0;        // decimated rate of the dynamic fit
  double burn_in_s = 1.5;       // residuals discarded at each chunk start (unknown initial state)
  double chunk_s = 60.0;        // long segments are simulated in independent chunks of this length
  double window_h = 20.0;       // re-identification window: most recent gated hours
  double period_s = 600.0;      // re-identify every this many seconds of *data* time
  double validation_fraction = 0.2;  // share of drives held out for validation RMSE
  int max_iterations = 50;
  int threads = 2;
  // Coarse start of large whole-window fits (docs/incremental.md): from coarse_min_chunks
  // chunks on, the solver first runs on every k-th chunk (about coarse_chunks of them) and then
  // finishes on all of them; coarse_min_chunks 0 turns it off. Not read from the YAML: the
  // optimum is the whole window's either way; tests and benchmarks set them.
  size_t coarse_min_chunks = 300;
  size_t coarse_chunks = 100;
  // identification.outputs: [a_y] or [a_y, yaw_rate]. With the yaw rate, both outputs' residuals
  // are fitted in one problem, each divided by its own noise level; chunks without a yaw rate
  // signal fall back to a_y alone. ParseConfig's default is [a_y, yaw_rate] when signals.yaw_rate
  // is configured and [a_y] otherwise; this struct's (for code that builds a config) is a_y alone.
  bool yaw_rate_output = false;
  // Incremental re-identification (docs/incremental.md): each periodic update fits the new data
  // plus the quadratic prior of the data already fitted; a prior segment is relinearised when
  // the estimate moved more than relinearize_sigma of the prior's standard deviation from its
  // linearisation point; every full_refit_every-th update (0: never on a schedule) and the final
  // fit at the end of data relinearise every chunk: the whole window's optimum.
  bool incremental = true;
  double relinearize_sigma = 5.0;
  int full_refit_every = 36;
  // Effect parameters held at a value instead of fitted (name -> value, clamped to the effect's
  // box). Not read from the YAML: the model-choice refits (pipeline/model_choice.h) attribute a
  // kinematic scale disagreement to one sensor by fixing its scale.
  std::vector<std::pair<std::string, double>> fixed_effect_params;
};

struct AdequacyConfig {
  double tolerance = 0.01;          // relative change / relative standard error of EG
  double hold_h = 2.0;              // both must stay under tolerance for this many gated hours
  double change_window_h = 2.0;     // EG's relative change is measured over this many gated hours
  double kl_threshold = 0.03;       // coverage growth (KL divergence, nats) considered flat
};

// Plausibility of the data and of the estimate (docs/monitoring.md): an estimate that fails a
// check is published with valid = false and the check's words as its reason.
struct PlausibilityConfig {
  double kinematic_gain_min = 0.8;       // a_y / (v r) regression gain, physically 1 (a_y = v (r + beta'))
  double kinematic_gain_max = 1.25;
  double kinematic_correlation_min = 0.7;
  double steer_yaw_correlation_min = 0.3;  // r against v d_sw: positive in ISO 8855
  double steer_ratio_min = 8;            // steady-state steering-wheel to road-wheel ratio
  double steer_ratio_max = 30;
  // ... where the steering role is a road-wheel angle (vehicle.steering_angle_at: road_wheels):
  // 1 but for compliance steer and the inner and outer wheels' mean.
  static constexpr double kRoadWheelSteerRatioMin = 0.7, kRoadWheelSteerRatioMax = 1.5;
  double eg_min_deg_per_g = -2;          // self-steering gradient of a road vehicle
  double eg_max_deg_per_g = 12;
  double eg_rel_se_max = 0.5;            // sigma(EG) / |EG| above this: not determined ...
  double eg_se_floor_deg_per_g = 0.25;   // ... unless sigma(EG) is below this (EG near 0 is fine)
  double min_informative_s = 20;         // a check needs this much informative data (else skipped)
  double wheel_speed_ratio_min = 0.9;    // vehicle_speed / wheel speeds' mean: 1 within tyre tolerances
  double wheel_speed_ratio_max = 1.1;
  double wheel_speed_correlation_min = 0.9;
  // Checks of the fit (adequacy/fit_checks.h, docs/monitoring.md):
  double rmse_floor_ratio_max = 5;       // held-out RMSE / the output's noise floor (white part of the residual)
  double rmse_spread_ratio_max = 0.5;    // held-out RMSE / the measured output's spread about zero
  // A held-out RMSE below this share of the output's spread passes the floor test whatever the
  // floor: noise-free data (a simulator's output) or a filtered sensor have a white floor near 0,
  // and a residual of a few per cent of the signal is no model failure there.
  double rmse_negligible_spread_ratio = 0.05;
  double bound_shift_sigma_max = 1.0;    // EG's move were the bounds released, in sigma(EG)
  double steady_state_z_max = 3;         // |dynamic EG - steady-state EG| / combined sigma
  double steady_state_rel_bias = 0.1;    // the steady-state regression's bias allowance, share of |EG|
  double halves_z_max = 3;               // |EG(half 1) - EG(half 2)| / combined sigma
  double model_choice_spread_rel_max = 0.25;  // EG's spread over the sensor-scale attributions / |EG|
};

struct LcmConfig {
  std::string url = "udpm://239.255.76.67:7667?ttl=0";
  std::string estimate_channel = "NDSID_ESTIMATE";
  std::string status_channel = "NDSID_STATUS";
  std::string monitor_channel = "NDSID_MONITOR";
  double status_rate_hz = 1.0;
  double monitor_rate_hz = 10.0;
};

// A hypothesis stated as a formula (docs/adding-an-effect.md): an effect without recompiling.
struct FormulaParam {
  std::string name;
  std::string unit;
  double lower = 0, upper = 0, initial = 0, neutral = 0;
};
// One equation of a formula effect: what it states (kFormulaTargets) and the expression.
struct FormulaTarget {
  std::string target;
  std::string expression;
};
// The targets a formula may state, in the order they are read: the measured outputs as functions
// (a_y_meas, r_meas), terms added to the state derivatives (beta_dot, r_dot), to an axle's slip
// angle (alpha_v, alpha_h) or to an axle's lateral force (F_v, F_h). docs/adding-an-effect.md.
inline constexpr const char* kFormulaTargets[] = {"a_y_meas", "r_meas", "beta_dot", "r_dot",
                                                  "alpha_v",  "alpha_h", "F_v",     "F_h"};
struct FormulaSpec {
  std::string name;                   // the effect's name in model.effects
  std::vector<FormulaTarget> targets;  // one or more, sharing the parameters
  std::vector<FormulaParam> params;
  std::string file;  // the configuration file and line, for located errors
  int line = 0;
};

struct VehicleConfig {
  std::string name;            // keys the learned state: a state from another vehicle is never loaded
  double wheelbase_m = 0;      // l, data sheet
  double mass_kg = 0;          // data sheet; m is fixed to it unless identification frees it
  // Optional data-sheet values (0: not given). The axle loads narrow the parameter box's lv
  // (parameter_box.h); the track widths let the rear wheel speeds give a yaw-rate reference.
  double front_axle_load_kg = 0, rear_axle_load_kg = 0;
  double track_front_m = 0, track_rear_m = 0;
  // The steering role carries the road wheels' angle instead of the steering wheel's
  // (vehicle.steering_angle_at: road_wheels; a research car's or a simulator's export): the steer
  // ratio is then about 1, and the parameter box and the steer-ratio check say so.
  bool road_wheel_angle = false;
};

struct Config {
  std::string path;            // the YAML file
  VehicleConfig vehicle;
  SourceConfig source;
  std::string dbc;             // resolved path
  std::array<std::optional<RoleSignal>, kNumRoles> roles;
  std::vector<ValiditySignal> validity;
  SyncConfig sync;
  GateConfig gate;
  IdentificationConfig identification;
  AdequacyConfig adequacy;
  PlausibilityConfig plausibility;
  LcmConfig lcm;
  std::string state_dir = "/var/lib/ndsid";
  // A learned state that exists but cannot be read (permissions, I/O error): stop with exit 78
  // (default), or run without persisting anything, leaving the file as it is.
  bool run_without_persisting_if_unreadable = false;  // state_unreadable: stop | run_without_persisting
  std::string report_dir = "out/report";
  std::string log_level = "info";
  std::vector<std::string> model_effects;  // effect names added to the base model
  std::vector<FormulaSpec> model_formulas; // model.formulas: user effects stated as formulas
  // model.alternatives: effects (library or formula) the data do not decide against the model;
  // each estimate refits the window with each one added and sigma(EG) covers the EGs of those the
  // held-out data do not rule out (the model_choice check; `ndsid diagnose --apply` writes them).
  std::vector<std::string> model_alternatives;
  // model.watch: effects whose score test is run at full-window and exact fits and where the
  // gated time has doubled (pipeline::WatchRequest); one the model lacks whose robust z
  // reaches pipeline::kSignificanceZ is refitted as an alternative like model.alternatives' (a
  // tyre that saturates inside the gate moves EG by a few per cent while the residual stays near
  // its floor). Effects already in model.effects or model.alternatives are left to those.
  std::vector<std::string> model_watch = {"tyre_saturation"};

  const RoleSignal* role(Role r) const { return roles[static_cast<int>(r)] ? &*roles[static_cast<int>(r)] : nullptr; }
};

// Loads and validates. Throws ConfigError "file:line: key.path: message" for unknown keys, wrong
// types, values out of range, missing required roles.
Config LoadConfig(const std::string& path);
Config ParseConfig(const std::string& yaml_text, const std::string& path_for_messages);

// Unit string -> factor to SI for a role (throws ConfigError on an unknown unit for that role).
double UnitToSi(Role role, const std::string& unit);

}  // namespace ndsid::config

namespace ndsid::dbc {
struct Database;
}

namespace ndsid::config {
// Every role and validity signal must exist in the DBC; throws ConfigError naming the YAML line
// and the missing message/signal.
void ValidateAgainstDbc(const Config& config, const dbc::Database& db);
}  // namespace ndsid::config
