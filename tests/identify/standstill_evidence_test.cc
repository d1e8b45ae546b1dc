// Standstill evidence (docs/two-outputs.md): the stops' mean yaw rate is the gyro offset and their
// mean a_y the accelerometer bias plus the cross-slope where the car stood. Identify turns the
// training drives' stops into priors on gyro_offset and accel_bias. Truths are the parameters the
// synthetic segments were generated with; the stops are drawn around the same truths.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <map>
#include <random>
#include <stdexcept>

#include "ndsid/identify/identifier.h"
#include "synthetic_segments.h"

namespace ndsid::identify {
namespace {

using ndsid::testing::kWheelbase;
using ndsid::testing::Pointers;
using ndsid::testing::SyntheticTwoOutputSegments;
using ndsid::testing::TruthParams;

constexpr double kDeg = M_PI / 180.0;
constexpr double kNoiseA = 0.05;
constexpr double kNoiseR = 0.1 * kDeg;

// `count` stops spread over drives 0..drives-1: a_y = bias + a cross-slope N(0, slope_sd), yaw rate
// = r0 + N(0, 0.02 deg/s) (a stop's mean over seconds of gyro noise).
std::vector<gate::StandstillStop> Stops(int count, int drives, double bias, double slope_sd, double r0, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> gauss(0.0, 1.0);
  std::vector<gate::StandstillStop> out;
  for (int i = 0; i < count; ++i) {
    gate::StandstillStop s;
    s.drive_id = i % drives;
    s.seconds = 20;
    s.samples = 2000;
    s.mean_lat_accel_mps2 = bias + slope_sd * gauss(rng);
    s.mean_yaw_rate_radps = r0 + 0.02 * kDeg * gauss(rng);
    out.push_back(s);
  }
  return out;
}

// The truth vector of `spec`: base six, then each effect parameter from `values` by name (else neutral).
std::vector<double> Truth(const model::ModelSpec& spec, const std::map<std::string, double>& values) {
  std::vector<double> t{1900, 2700, 75000, 120000, 1.15, 14.8};
  for (int i = model::kNumParams; i < spec.num_params(); ++i) {
    const auto it = values.find(spec.param_name(i));
    t.push_back(it != values.end() ? it->second : spec.effect_param(i)->neutral);
  }
  return t;
}

const ParameterEstimate& Param(const IdentificationResult& r, const std::string& name) {
  for (const auto& p : r.effect_params)
    if (p.name == name) return p;
  throw std::runtime_error("no parameter " + name);
}

bool HasNote(const IdentificationResult& r, const std::string& text) {
  for (const auto& n : r.identifiability.notes)
    if (n.find(text) != std::string::npos) return true;
  return false;
}

// Catches: standstill evidence ignored (no tighter accel_bias, no note), used with the wrong
// sign, or taken from drives the fit does not train on. Three seeds, an a_y-only fit of
// accel_bias with steer_offset (a steering offset leaves a near-constant a_y too).
TEST(StandstillEvidence, StopsPinTheAccelerometerBias) {
  for (uint64_t seed : {61u, 62u, 63u}) {
    const double bias = seed == 62 ? -0.11 : 0.13;
    const model::ModelSpec truth_spec = model::ModelSpec::FromNames({"crossfall", "accel_bias"});
    const std::vector<double> truth = Truth(truth_spec, {{"accel_bias_mps2", bias}});
    const auto train = SyntheticTwoOutputSegments(truth_spec, truth, 12, 60, kNoiseA, kNoiseR, seed, 0.2);
    config::IdentificationConfig cfg = ndsid::testing::DefaultIdentificationConfig();
    Identifier id(cfg, kWheelbase, model::ModelSpec::FromNames({"road_bank", "accel_bias", "steer_offset"}));
    const IdentificationResult without = id.Identify(Pointers(train), {});
    id.set_standstill(Stops(24, 12, bias, 0.15, 0.0, seed));
    const IdentificationResult with = id.Identify(Pointers(train), {});
    ASSERT_TRUE(without.valid && with.valid);
    const auto& b0 = Param(without, "accel_bias_mps2");
    const auto& b1 = Param(with, "accel_bias_mps2");
    std::printf("seed %llu: accel_bias truth %+.3f: without stops %+.4f +- %.4f, with 24 stops %+.4f +- %.4f m/s^2\n",
                static_cast<unsigned long long>(seed), bias, b0.value, b0.se, b1.value, b1.se);
    EXPECT_LT(b1.se, 0.8 * b0.se) << "the stops add information";
    EXPECT_NEAR(b1.value, bias, 3 * b1.se + 0.005);
    EXPECT_TRUE(HasNote(with, "standstill evidence on accel_bias_mps2"));
    EXPECT_FALSE(HasNote(without, "standstill evidence"));

    // Stops of drives outside the training set, or too few of them: no evidence.
    auto other = Stops(24, 3, bias + 0.3, 0.01, 0.0, seed);
    for (auto& s : other) s.drive_id += 100;
    id.set_standstill(other);
    EXPECT_FALSE(HasNote(id.Identify(Pointers(train), {}), "standstill evidence"));
    id.set_standstill(Stops(static_cast<int>(Identifier::kMinStops) - 1, 4, bias + 0.3, 0.01, 0.0, seed));
    EXPECT_FALSE(HasNote(id.Identify(Pointers(train), {}), "standstill evidence"));
  }
}

// Catches: a gyro offset prior on the wrong scale (rad/s vs deg/s) or sign, or stops that
// override good moving data. (1) With road_bank the moving data already fix r0 (the observer
// reads r_meas - r0): the stops agree and change nothing. (2) Without road_bank an a_y-only fit
// has no information on r0 at all: the stops decide it, with their standard error.
TEST(StandstillEvidence, StopsGiveTheGyroOffset) {
  const double r0 = -0.35 * kDeg;
  const model::ModelSpec truth_spec = model::ModelSpec::FromNames({"crossfall", "gyro_offset"});
  const std::vector<double> truth = Truth(truth_spec, {{"gyro_offset_radps", r0}});
  const auto train = SyntheticTwoOutputSegments(truth_spec, truth, 12, 60, kNoiseA, kNoiseR, 64, 0.2);
  config::IdentificationConfig cfg = ndsid::testing::DefaultIdentificationConfig();
  const auto stops = Stops(10, 12, 0.0, 0.15, r0, 64);
  double stop_mean = 0;
  for (const auto& s : stops) stop_mean += s.mean_yaw_rate_radps / static_cast<double>(stops.size());

  Identifier bank(cfg, kWheelbase, model::ModelSpec::FromNames({"road_bank", "gyro_offset"}));
  const IdentificationResult without = bank.Identify(Pointers(train), {});
  bank.set_standstill(stops);
  const IdentificationResult with = bank.Identify(Pointers(train), {});
  ASSERT_TRUE(without.valid && with.valid);
  const auto& g0 = Param(without, "gyro_offset_radps");
  const auto& g1 = Param(with, "gyro_offset_radps");
  std::printf("road_bank + gyro_offset, truth %+.3f deg/s: without stops %+.4f +- %.4f, with 10 stops %+.4f +- %.4f deg/s\n",
              r0 / kDeg, g0.value / kDeg, g0.se / kDeg, g1.value / kDeg, g1.se / kDeg);
  EXPECT_NEAR(g1.value, r0, 0.02 * std::abs(r0));
  EXPECT_NEAR(g1.value, g0.value, 3 * g0.se) << "consistent stops leave well-determined data alone";
  EXPECT_TRUE(HasNote(with, "standstill evidence on gyro_offset_radps"));
  EXPECT_FALSE(HasNote(with, "standstill evidence on accel_bias")) << "no accel_bias in the model";

  Identifier plain(cfg, kWheelbase, model::ModelSpec::FromNames({"gyro_offset"}));
  plain.set_standstill(stops);
  const IdentificationResult only = plain.Identify(Pointers(train), {});
  ASSERT_TRUE(only.valid) << only.reason;
  const auto& g2 = Param(only, "gyro_offset_radps");
  std::printf("gyro_offset without road_bank (a_y alone says nothing): %+.4f +- %.4f deg/s, stops' mean %+.4f deg/s\n",
              g2.value / kDeg, g2.se / kDeg, stop_mean / kDeg);
  EXPECT_NEAR(g2.value, stop_mean, 1e-3 * std::abs(r0));
  EXPECT_NEAR(g2.value, r0, 0.03 * kDeg);
  EXPECT_GT(g2.se, 0.0);
  EXPECT_LT(g2.se, 0.02 * kDeg);
}

}  // namespace
}  // namespace ndsid::identify
