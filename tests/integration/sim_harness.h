// Integration-test harness: simulate drives of a known vehicle with the simulator, write them
// as the bus carries them (candump log, example DBC), replay the log through the real pipeline
// (reader -> decoder -> sync -> gate -> statistics) and hand back the window and the truth.
#pragma once

#include <cmath>
#include <filesystem>
#include <map>
#include <memory>
#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/model/model_spec.h"
#include "ndsid/sim/candump_writer.h"
#include "ndsid/sim/simulator.h"
#include "ndsid/pipeline/pipeline.h"
#include "replay_runner.h"

namespace ndsid::testing {

struct SimulatedRun {
  config::SimulationConfig sim;
  std::unique_ptr<config::Config> config;
  std::unique_ptr<dbc::Database> db;
  std::unique_ptr<pipeline::Pipeline> pipeline;
  pipeline::WindowSnapshot window;
  double eg_truth = 0;                // rad/(m/s^2)
  std::vector<double> truth_base;     // m, Jz, cv, ch, lv, is
  std::vector<double> drive_gyro_offset_degps;  // each drive's gyro offset (index = drive id)
  std::vector<pipeline::Estimate> history; // periodic estimates (ReplayOptions::identify_periodically)
};

// How the log is replayed: by default only read (the tests fit the window themselves); with
// identify_every_s > 0 the pipeline re-identifies every that many seconds of data time, as the
// daemon does, and the run keeps the history of estimates with their adequacy reports.
struct ReplayTweaks {
  double identify_every_s = 0;
  std::vector<double> mass_schedule_kg;  // simulator: extra mass of drive i = schedule[i % size]
  // The pipeline's outputs. The example config fits both (its yaw rate makes that the default);
  // the harness's replays were measured on a_y alone, and the tests of both outputs refit with
  // their own IdentificationConfig.
  bool yaw_rate_output = false;
  double lowpass_hz = 0;  // signals.<role>.lowpass_hz on a_y and the yaw rate (0: none)
  // The simulator's bus: messages at their own cycles and frames lost (docs/simulator.md, "Low
  // and irregular rates"); timeout_s > 0: every role's and validity flag's timeout, as a user sets
  // it for a slow bus.
  std::map<std::string, double> message_cycle_ms;
  double frame_loss_pct = 0;
  double timeout_s = 0;
  int parking_turns = 0;  // simulator: road.parking_turns (tight turns at walking pace)
  bool noise_free = false;  // simulator: no sensor noise and no a_y disturbance (only the DBC's quantisation)
  std::vector<std::string> alternatives;  // model.alternatives
  std::vector<config::FormulaSpec> formulas;  // model.formulas
  double rear_stiffness_factor = 1.0;  // simulator: the car's rear cornering stiffness times this (the truth follows)
};

inline std::string TempDir(const std::string& name) {
  const auto dir = std::filesystem::temp_directory_path() / ("ndsid_it_" + name + "_" + std::to_string(::getpid()));
  std::filesystem::create_directories(dir);
  return dir.string();
}

// effects: simulator assignments such as "steer_offset_deg=1.5"; model_effects: the model to fit
// (default: the example vehicle's, base + road_bank).
inline SimulatedRun SimulateAndReplay(const std::string& name, uint64_t seed, double hours,
                                      const std::vector<std::string>& effects = {},
                                      const std::vector<std::string>& model_effects = {"road_bank"},
                                      const ReplayTweaks& tweaks = {}) {
  SimulatedRun run;
  run.sim.seed = seed;
  run.sim.duration.hours = hours;
  for (const auto& e : effects) config::ApplyEffect(run.sim.effects, e);
  run.sim.effects.mass_schedule_kg = tweaks.mass_schedule_kg;
  run.sim.bus.message_cycle_ms = tweaks.message_cycle_ms;
  run.sim.bus.frame_loss_pct = tweaks.frame_loss_pct;
  run.sim.road.parking_turns = tweaks.parking_turns;
  run.sim.vehicle.cornering_stiffness_rear_npr *= tweaks.rear_stiffness_factor;
  if (tweaks.noise_free) {
    const double tau = run.sim.noise.lat_accel_disturbance_tau_s;
    run.sim.noise = config::SimNoise{0, 0, 0, 0, 0, 0, tau};
  }
  const std::string src = NDSID_SOURCE_DIR;
  run.config = std::make_unique<config::Config>(config::LoadConfig(src + "/config/example_vehicle.yaml"));
  run.config->model_effects = model_effects;
  run.config->model_alternatives = tweaks.alternatives;
  run.config->model_formulas = tweaks.formulas;
  run.config->identification.yaw_rate_output = tweaks.yaw_rate_output;
  if (tweaks.identify_every_s > 0) run.config->identification.period_s = tweaks.identify_every_s;
  for (config::Role role : {config::Role::kLateralAcceleration, config::Role::kYawRate}) {
    if (run.config->roles[static_cast<int>(role)]) run.config->roles[static_cast<int>(role)]->lowpass_hz = tweaks.lowpass_hz;
  }
  if (tweaks.timeout_s > 0) {
    for (auto& r : run.config->roles)
      if (r) r->timeout_s = tweaks.timeout_s;
    for (auto& v : run.config->validity) v.timeout_s = tweaks.timeout_s;
  }
  run.db = std::make_unique<dbc::Database>(dbc::ParseDbcFile(run.config->dbc));
  const std::string log = TempDir(name) + "/drive.log";
  {
    const sim::SimulationResult result = sim::Simulate(run.sim);
    for (const auto& d : result.drives) run.drive_gyro_offset_degps.push_back(d.gyro_offset_degps);
    sim::WriteCandumpLog(result, *run.db, log);
  }
  const auto& v = run.sim.vehicle;
  run.truth_base = {v.mass_kg, v.yaw_inertia_kgm2, v.cornering_stiffness_front_npr, v.cornering_stiffness_rear_npr,
                    v.cg_to_front_m, v.steering_ratio};
  run.eg_truth = model::SelfSteerGradient(model::Params<double>::FromArray(run.truth_base.data()), v.wheelbase_m);
  run.pipeline = std::make_unique<pipeline::Pipeline>(*run.config, *run.db);
  desk::ReplayOptions opt;
  opt.logs = {log};
  opt.identify_periodically = tweaks.identify_every_s > 0;
  run.history = desk::RunReplay(*run.pipeline, *run.config, opt).history;
  run.window = run.pipeline->Snapshot();
  std::filesystem::remove_all(std::filesystem::path(log).parent_path());
  return run;
}

// The model's parameter vector at the simulator's truth: base parameters and, for each effect
// of `spec`, the simulated magnitude converted to the model's parameter (neutral if not simulated).
inline std::vector<double> TruthVector(const SimulatedRun& run, const model::ModelSpec& spec) {
  std::vector<double> p = run.truth_base;
  const auto& e = run.sim.effects;
  for (int i = model::kNumParams; i < spec.num_params(); ++i) {
    const std::string n = spec.param_name(i);
    double v = spec.effect_param(i)->neutral;
    if (n == "accel_bias_mps2") v = e.accel_bias_mps2;
    if (n == "steer_offset_rad") v = e.steer_offset_deg * M_PI / 180;
    if (n == "roll_gradient_rad_per_mps2") v = e.roll_gradient_deg_per_g * M_PI / 180 / 9.81;
    if (n == "superelevation") v = e.superelevation_pct / 100;
    if (n == "lever_arm_m") v = e.lever_arm_m;
    if (n == "tyre_inv_mu_sq" && e.tyre_mu > 0) v = 1.0 / (e.tyre_mu * e.tyre_mu);
    if (n == "relaxation_length_m" && e.relaxation_length_m > 0) v = e.relaxation_length_m;
    if (n == "steer_delay_s") v = e.steer_delay_ms / 1000;
    if (n == "speed_delay_s") v = e.speed_delay_ms / 1000;
    if (n == "speed_scale") v = e.speed_scale_pct / 100;
    if (n == "speed_offset_mps") v = e.speed_offset_kph / 3.6;
    if (n == "accel_scale") v = e.accel_scale_pct / 100;
    if (n == "gyro_offset_radps") v = e.gyro_offset_degps * M_PI / 180;
    if (n == "gyro_scale") v = e.gyro_scale_pct / 100;
    if (n == "gyro_delay_s") v = e.gyro_delay_ms / 1000;
    if (n == "road_bank_gain") v = 1.0;  // the simulated road is banked: the bank as measured
    p.push_back(v);
  }
  return p;
}

// The noise floor: the RMSE of the true model (base + `effects` at the simulated values, see
// TruthVector) on the run's held-out drives, with the run's identification settings.
inline double NoiseFloor(const SimulatedRun& run, const model::ModelSpec& spec) {
  const identify::Identifier truth_model(run.config->identification, run.config->vehicle.wheelbase_m, spec);
  return truth_model.Rmse(TruthVector(run, spec), run.window.validation);
}

// The estimate's check named `name` (nullptr when it was not made), and every check as lines
// "name verdict: message" for a failure's message.
inline const adequacy::Check* FindCheck(const pipeline::Estimate& e, const std::string& name) {
  for (const adequacy::Check& c : e.plausibility.checks)
    if (c.name == name) return &c;
  return nullptr;
}
inline std::string CheckList(const pipeline::Estimate& e) {
  std::string out;
  for (const adequacy::Check& c : e.plausibility.checks)
    out += c.name + " " + adequacy::VerdictName(c.verdict) + ": " + c.message + "\n";
  return out;
}

}  // namespace ndsid::testing
