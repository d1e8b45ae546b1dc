// Test data for the identifier: segments of a known single-track vehicle driven with smooth
// random steering and speed, integrated at 1 kHz (not the identifier's 50 Hz) and sampled at
// 50 Hz with white noise on a_y. Fixed seeds, so failures reproduce.
#pragma once

#include <cmath>
#include <random>
#include <utility>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/discover/alignment.h"
#include "ndsid/model/simulate.h"
#include "ndsid/stats/segment.h"

namespace ndsid::testing {

// The smallest vehicle file the config loader accepts (the simulator's car: l 2.648 m, m 1900 kg);
// tests append the sections they need.
inline constexpr const char* kMinimalVehicleYaml = R"(vehicle: {name: t, wheelbase_m: 2.648, mass_kg: 1900}
source: {type: log, logs: [x.log]}
dbc: x.dbc
signals:
  steering_wheel_angle: {message: A, signal: B, unit: deg}
  vehicle_speed: {message: A, signal: C, unit: km/h}
  lateral_acceleration: {message: A, signal: D, unit: m/s^2}
identification:
  parameters:
    m: {min: 1800, max: 2000, fixed: true}
    Jz: {min: 2200, max: 3200}
    cv: {min: 65000, max: 90000}
    ch: {min: 110000, max: 135000}
    lv: {min: 1.0, max: 1.3}
    is: {min: 14.2, max: 15.3}
)";

// The identification settings of the synthetic car's vehicle file (the study's box of its class,
// as config/example_vehicle.yaml states it; m fixed at the data-sheet 1900 kg), through the real
// config loader.
inline config::IdentificationConfig DefaultIdentificationConfig() {
  return config::ParseConfig(kMinimalVehicleYaml, "test.yaml").identification;
}

inline model::Params<double> TruthParams() { return {1900, 2700, 75000, 120000, 1.15, 14.8}; }
// The same as a parameter vector (base six, ModelSpec order), to append effects' truths to.
inline std::vector<double> TruthVector() {
  const auto p = TruthParams();
  return {p.m, p.Jz, p.cv, p.ch, p.lv, p.is};
}
inline constexpr double kWheelbase = 2.648;

// A truth with a road crossfall (its parameter 0: no bank offset) and a 0.3 deg/s gyro offset:
// the two-output tests' simulated car. Returns the model and its parameter vector.
inline std::pair<model::ModelSpec, std::vector<double>> CrossfallGyroOffsetTruth() {
  std::vector<double> truth = TruthVector();
  truth.push_back(0.0);
  truth.push_back(0.3 * M_PI / 180.0);
  return {model::ModelSpec::FromNames({"crossfall", "gyro_offset"}), truth};
}

// Smooth random inputs of one segment: steering a sum of 4 sinusoids (0.05..0.6 Hz) of up to
// ~40 deg at the wheel, speed 8..35 m/s with a slow swing.
struct RandomInputs {
  double amp[4], freq[4], phase[4], v0, dv, fv;
  explicit RandomInputs(std::mt19937_64& rng) {
    std::uniform_real_distribution<double> uni(0.0, 1.0);
    for (int i = 0; i < 4; ++i) {
      amp[i] = (0.05 + 0.15 * uni(rng)) / (1 + i);
      freq[i] = 0.05 + 0.55 * uni(rng);
      phase[i] = 2 * M_PI * uni(rng);
    }
    v0 = 8 + 27 * uni(rng);
    dv = 3 * uni(rng);
    fv = 0.01 + 0.03 * uni(rng);
  }
  double steer(double t) const {
    double d = 0;
    for (int i = 0; i < 4; ++i) d += amp[i] * std::sin(2 * M_PI * freq[i] * t + phase[i]);
    return d;
  }
  double speed(double t) const { return v0 + dv * std::sin(2 * M_PI * fv * t); }
};

inline std::vector<stats::Segment> SyntheticSegments(int count, double seconds, double noise_mps2, uint64_t seed,
                                                     const model::Params<double>& p = TruthParams()) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<stats::Segment> out;
  constexpr double kFine = 0.001, kDt = 0.02;
  for (int s = 0; s < count; ++s) {
    const RandomInputs inputs(rng);
    auto steer = [&](double t) { return inputs.steer(t); };
    auto speed = [&](double t) { return inputs.speed(t); };
    stats::Segment seg;
    seg.drive_id = s;
    seg.dt_s = kDt;
    seg.has_yaw_rate = true;
    model::State<double> x = model::SteadyState(p, kWheelbase, steer(0), speed(0));
    const int steps_per_sample = static_cast<int>(std::lround(kDt / kFine));
    const int n = static_cast<int>(seconds / kDt);
    for (int k = 0; k < n; ++k) {
      const double t = k * kDt;
      const auto d = model::LinearDerivative(p, kWheelbase, x, steer(t), speed(t));
      seg.samples.push_back({static_cast<float>(steer(t)), static_cast<float>(speed(t)),
                             static_cast<float>(d.a_y + noise_mps2 * gauss(rng)), static_cast<float>(x.r), 0.0f});
      for (int j = 0; j < steps_per_sample; ++j) {
        const double t0 = t + j * kFine;
        model::Rk4Step(p, kWheelbase, x, steer(t0), steer(t0 + kFine), speed(t0), speed(t0 + kFine), kFine);
      }
    }
    out.push_back(std::move(seg));
  }
  return out;
}

using identify::Pointers;

}  // namespace ndsid::testing

namespace ndsid::testing {

// Like SyntheticSegments, but the truth is the full model `spec` with parameters `truth`
// (base six then effects), integrated at 1 kHz with the model's own loop and sampled at 50 Hz.
inline std::vector<stats::Segment> SyntheticSegmentsWithEffects(const model::ModelSpec& spec,
                                                                const std::vector<double>& truth, int count,
                                                                double seconds, double noise_mps2, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<stats::Segment> out;
  constexpr double kFine = 0.001, kDt = 0.02;
  constexpr int kDecimate = 20;
  for (int s = 0; s < count; ++s) {
    const RandomInputs inputs(rng);
    const size_t n_fine = static_cast<size_t>(seconds / kFine);
    std::vector<float> in(2 * n_fine);
    for (size_t k = 0; k < n_fine; ++k) {
      in[2 * k] = static_cast<float>(inputs.steer(k * kFine));
      in[2 * k + 1] = static_cast<float>(inputs.speed(k * kFine));
    }
    std::vector<double> y(n_fine);
    model::SimulateModel(spec, truth.data(), kWheelbase, model::InputSeries{&in[0], &in[1], 2, n_fine, kFine},
                         y.data());
    stats::Segment seg;
    seg.drive_id = s;
    seg.dt_s = kDt;
    for (size_t k = 0; k < n_fine; k += kDecimate) {
      seg.samples.push_back({in[2 * k], in[2 * k + 1], static_cast<float>(y[k] + noise_mps2 * gauss(rng)), 0.0f, 0.0f});
    }
    out.push_back(std::move(seg));
  }
  return out;
}

}  // namespace ndsid::testing

namespace ndsid::testing {

// Two outputs: like SyntheticSegmentsWithEffects, but every segment also carries the modelled
// *measured* yaw rate (r plus the truth's yaw-rate measurement terms, e.g. gyro_offset) with
// white noise noise_radps. When crossfall_sd_mps2 > 0, `spec` must contain "crossfall": each
// segment gets its own crossfall drawn from N(0, sd) (a road bank constant along the segment),
// returned in crossfall_out (one per segment) when given.
inline std::vector<stats::Segment> SyntheticTwoOutputSegments(const model::ModelSpec& spec, std::vector<double> truth,
                                                               int count, double seconds, double noise_mps2,
                                                               double noise_radps, uint64_t seed,
                                                               double crossfall_sd_mps2 = 0.0,
                                                               std::vector<double>* crossfall_out = nullptr) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  int crossfall_index = -1;
  for (int i = 0; i < spec.num_params(); ++i) {
    if (spec.param_name(i) == "crossfall_mps2") crossfall_index = i;
  }
  std::vector<stats::Segment> out;
  constexpr double kFine = 0.001, kDt = 0.02;
  constexpr int kDecimate = 20;
  for (int s = 0; s < count; ++s) {
    const RandomInputs inputs(rng);
    if (crossfall_sd_mps2 > 0 && crossfall_index >= 0) {
      truth[static_cast<size_t>(crossfall_index)] = crossfall_sd_mps2 * gauss(rng);
      if (crossfall_out) crossfall_out->push_back(truth[static_cast<size_t>(crossfall_index)]);
    }
    const size_t n_fine = static_cast<size_t>(seconds / kFine);
    std::vector<float> in(2 * n_fine);
    for (size_t k = 0; k < n_fine; ++k) {
      in[2 * k] = static_cast<float>(inputs.steer(k * kFine));
      in[2 * k + 1] = static_cast<float>(inputs.speed(k * kFine));
    }
    std::vector<double> y(n_fine), r(n_fine);
    model::SimulateModel(spec, truth.data(), kWheelbase, model::InputSeries{&in[0], &in[1], 2, n_fine, kFine},
                         y.data(), nullptr, r.data());
    stats::Segment seg;
    seg.drive_id = s;
    seg.dt_s = kDt;
    seg.has_yaw_rate = true;
    for (size_t k = 0; k < n_fine; k += kDecimate) {
      const double a = y[k] + noise_mps2 * gauss(rng);
      const double yaw = r[k] + noise_radps * gauss(rng);
      seg.samples.push_back({in[2 * k], in[2 * k + 1], static_cast<float>(a), static_cast<float>(yaw), 0.0f});
    }
    out.push_back(std::move(seg));
  }
  return out;
}

}  // namespace ndsid::testing
