#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <string>
#include <vector>

#include "ndsid/common/error.h"
#include "ndsid/model/model_spec.h"
#include "ndsid/model/simulate.h"

namespace ndsid::model {
namespace {

constexpr double kL = 2.648;
const std::vector<double> kBase = {1900, 2700, 75000, 120000, 1.15, 14.8};

// A 20 s stretch at 50 Hz: sinusoidal steering (0.4 Hz, 30 deg) at 15 -> 25 m/s.
struct Stretch {
  std::vector<float> data;  // interleaved steer, speed
  size_t n = 1000;
  double dt = 0.02;
  Stretch() {
    data.resize(2 * n);
    for (size_t k = 0; k < n; ++k) {
      data[2 * k] = static_cast<float>(0.5 * std::sin(2 * M_PI * 0.4 * k * dt));
      data[2 * k + 1] = static_cast<float>(15.0 + 10.0 * k / n);
    }
  }
  InputSeries series() const { return {&data[0], &data[1], 2, n, dt}; }
};

std::vector<double> Simulate(const ModelSpec& spec, const std::vector<double>& p, const Stretch& s,
                             SimulationTrace* trace = nullptr) {
  std::vector<double> out(s.n);
  SimulateModel(spec, p.data(), kL, s.series(), out.data(), trace);
  return out;
}

std::vector<double> With(std::vector<double> base, double eta) {
  base.push_back(eta);
  return base;
}

// Catches: an effect that changes the model at its neutral value (the base model must nest).
TEST(Effects, EveryEffectVanishesAtItsNeutralValue) {
  const Stretch s;
  const auto base = Simulate(ModelSpec{}, kBase, s);
  for (const std::string& name : BuiltinEffectNames()) {
    const ModelSpec spec = ModelSpec::FromNames({name});
    const auto y = Simulate(spec, With(kBase, spec.effect_param(6)->neutral), s);
    // Relaxation's neutral value is its lower bound, 1 mm (tau = 50 us): nearly, not exactly, zero.
    const double tol = name == "relaxation" ? 1e-3 : 1e-9;
    for (size_t k = 0; k < s.n; k += 7) ASSERT_NEAR(y[k], base[k], tol) << name << " at " << k;
  }
}

// Catches: a measurement term that does not follow its equation sample by sample.
TEST(Effects, MeasurementTermsFollowTheirEquations) {
  const Stretch s;
  SimulationTrace trace;
  const auto base = Simulate(ModelSpec{}, kBase, s, &trace);
  const auto bias = Simulate(ModelSpec::FromNames({"accel_bias"}), With(kBase, 0.1), s);
  const auto lever = Simulate(ModelSpec::FromNames({"lever_arm"}), With(kBase, 0.8), s);
  for (size_t k = 1; k + 1 < s.n; ++k) {
    EXPECT_NEAR(bias[k] - base[k], 0.1, 1e-9);
    // r' by central difference of the traced yaw rate.
    const double r_dot = (trace.yaw_rate_radps[k + 1] - trace.yaw_rate_radps[k - 1]) / (2 * s.dt);
    EXPECT_NEAR(lever[k] - base[k], 0.8 * r_dot, 2e-3);
  }
}

// Catches: the steering offset applied with the wrong sign (d_sw,true = d_sw,meas - d0).
TEST(Effects, SteerOffsetEqualsShiftedInput) {
  Stretch s, shifted;
  for (size_t k = 0; k < s.n; ++k) shifted.data[2 * k] = static_cast<float>(s.data[2 * k] - 0.02);
  const auto a = Simulate(ModelSpec::FromNames({"steer_offset"}), With(kBase, 0.02), s);
  const auto b = Simulate(ModelSpec{}, kBase, shifted);
  for (size_t k = 0; k < s.n; ++k) EXPECT_NEAR(a[k], b[k], 1e-6);
}

// Catches: a time skew shifting the wrong way (steering measured late -> use a later sample).
TEST(Effects, SteerDelayOfWholeSamplesEqualsShiftedInput) {
  Stretch s, shifted;
  for (size_t k = 0; k + 3 < s.n; ++k) shifted.data[2 * k] = s.data[2 * (k + 3)];
  const auto a = Simulate(ModelSpec::FromNames({"steer_delay"}), With(kBase, 3 * s.dt), s);
  const auto b = Simulate(ModelSpec{}, kBase, shifted);
  for (size_t k = 0; k + 3 < s.n; ++k) EXPECT_NEAR(a[k], b[k], 1e-6) << k;
}

// Catches: roll gain not reaching g*k_phi*a_y in steady cornering.
TEST(Effects, RollReachesSteadyGainInConstantCorner) {
  Stretch s;
  for (size_t k = 0; k < s.n; ++k) {
    s.data[2 * k] = 0.3f;
    s.data[2 * k + 1] = 20.0f;
  }
  const double k_phi = 0.0089;  // 5 deg/g
  const auto base = Simulate(ModelSpec{}, kBase, s);
  const auto roll = Simulate(ModelSpec::FromNames({"roll"}), With(kBase, k_phi), s);
  EXPECT_NEAR(roll.back() - base.back(), 9.81 * k_phi * base.back(), 1e-6);
}

// Catches: autodiff derivatives that disagree with the equations (every effect, every input):
// the Jacobian that drives Ceres and the diagnosis must match central differences.
TEST(Effects, AutodiffMatchesNumericDerivatives) {
  const Stretch s;
  for (const std::string& name : BuiltinEffectNames()) {
    const ModelSpec spec = ModelSpec::FromNames({name});
    const EffectParam* ep = spec.effect_param(6);
    // Off the sample grid (1.07 x typical): the time shift's interpolation has kinks at whole samples.
    std::vector<double> p = With(kBase, 1.07 * ep->typical);
    std::vector<Jet> pj(p.size());
    for (size_t i = 0; i < p.size(); ++i) pj[i] = Jet(p[i], static_cast<int>(i));
    std::vector<Jet> yj(s.n);
    SimulateModel(spec, pj.data(), kL, s.series(), yj.data());
    for (int i : {2, 5, 6}) {  // cv, is, the effect's parameter
      const double h = 1e-6 * std::max(1.0, std::abs(p[static_cast<size_t>(i)]));
      auto pp = p, pm = p;
      pp[static_cast<size_t>(i)] += h;
      pm[static_cast<size_t>(i)] -= h;
      const auto yp = Simulate(spec, pp, s), ym = Simulate(spec, pm, s);
      double max_err = 0, max_ref = 0;
      for (size_t k = 50; k < s.n; k += 5) {
        const double num = (yp[k] - ym[k]) / (2 * h);
        max_err = std::max(max_err, std::abs(num - yj[k].v[i]));
        max_ref = std::max(max_ref, std::abs(num));
      }
      EXPECT_LE(max_err, 1e-4 * max_ref + 1e-9) << name << " d/d" << spec.param_name(i);
    }
  }
}

// Catches: a road-bank observer that does not find the bank, or acts without a yaw rate. The
// truth drives the stretch on a constant 3 % crossfall (the crossfall effect); road_bank, given
// only the truth's yaw rate and starting from no bank, must reproduce the truth's a_y once the
// observer has settled (tau_o = 1 s), and without a yaw rate it must equal the base model.
TEST(Effects, RoadBankObserverFindsTheBankFromTheYawRate) {
  const Stretch s;
  const double g_y = 0.03 * 9.81;
  SimulationTrace truth_trace;
  const auto truth = Simulate(ModelSpec::FromNames({"crossfall"}), With(kBase, g_y), s, &truth_trace);
  std::vector<float> with_r(3 * s.n);
  for (size_t k = 0; k < s.n; ++k) {
    with_r[3 * k] = s.data[2 * k];
    with_r[3 * k + 1] = s.data[2 * k + 1];
    with_r[3 * k + 2] = static_cast<float>(truth_trace.yaw_rate_radps[k]);
  }
  InputSeries in{&with_r[0], &with_r[1], 3, s.n, s.dt};
  in.yaw_rate_radps = &with_r[2];
  const ModelSpec bank = ModelSpec::FromNames({"road_bank"});
  const std::vector<double> p = With(kBase, 1.0);
  std::vector<double> model(s.n);
  SimulateModel(bank, p.data(), kL, in, model.data());
  const auto base = Simulate(ModelSpec{}, kBase, s);
  double worst_base = 0, worst_model = 0;
  for (size_t k = s.n / 2; k < s.n; ++k) {  // after 10 s
    worst_base = std::max(worst_base, std::abs(truth[k] - base[k]));
    worst_model = std::max(worst_model, std::abs(truth[k] - model[k]));
  }
  EXPECT_GT(worst_base, 0.05);   // the bank matters: the base model misses it
  EXPECT_LT(worst_model, 0.01);  // the observer found it
  const auto no_yaw = Simulate(bank, p, s);  // Stretch::series() carries no yaw rate
  for (size_t k = 0; k < s.n; ++k) ASSERT_NEAR(no_yaw[k], base[k], 1e-9) << k;
}

TEST(ModelSpec, OrdersEffectsAndRejectsUnknownOrRepeated) {
  const ModelSpec spec = ModelSpec::FromNames({"roll", "steer_offset"});
  EXPECT_EQ(spec.effect_names(), (std::vector<std::string>{"steer_offset", "roll"}));
  EXPECT_EQ(spec.num_params(), 8);
  EXPECT_EQ(spec.param_name(6), "steer_offset_rad");
  EXPECT_EQ(spec.Describe(), "single-track + steer_offset + roll");
  EXPECT_THROW(ModelSpec::FromNames({"warp_drive"}), ConfigError);
  EXPECT_THROW(ModelSpec::FromNames({"roll", "roll"}), ConfigError);
}


// Catches: an effect's term marked absent (Effect::terms(), found by EffectImpl at compile time)
// although the effect defines it: SimulateModel skips the terms marked absent, so the term would
// silently drop out of every simulation. Each term marked absent must be the default's no-op at
// the effect's typical (non-neutral) parameter values; and two effects' terms are the hooks
// their sources define (a detection that marks every term present would only cost time).
TEST(Effects, TermsMarkedAbsentAreNoOps) {
  const Stretch s;
  const InputSeries series = s.series();
  const Params<double> p = Params<double>::FromArray(kBase.data());
  const State<double> x{0.01, 0.2};
  const AxleSlip<double> slip{0.02, -0.01};
  const MeasurementContext<double> m{2.0, 0.3, 0.2, 20.0};
  const ModelInputs<double> u{0.1, 20.0, 0.05, 0.21, true};
  for (const std::string& name : BuiltinEffectNames()) {
    const ModelSpec spec = ModelSpec::FromNames({name});
    const Effect& effect = *spec.effects().at(0);
    const Effect::Terms t = effect.terms();
    std::vector<double> eta;
    for (int i = kNumParams; i < spec.num_params(); ++i) eta.push_back(spec.effect_param(i)->typical);
    const std::vector<double> states0(static_cast<size_t>(std::max(1, spec.num_states())), 0.37);
    if (!t.inputs) {
      ModelInputs<double> v = u;
      effect.Inputs(eta.data(), series, 10, v);
      EXPECT_TRUE(v.steer_rad == u.steer_rad && v.speed_mps == u.speed_mps && v.bank_mps2 == u.bank_mps2 &&
                  v.yaw_rate_meas_radps == u.yaw_rate_meas_radps) << name;
    }
    if (!t.forces) {
      ForceTerms<double> f{1000.0, 2000.0, 0.1, 0.2};
      effect.Forces(eta.data(), p, kL, slip, x, u, states0.data(), f);
      EXPECT_TRUE(f.force_front_n == 1000.0 && f.force_rear_n == 2000.0 && f.gravity_lat_mps2 == 0.1 &&
                  f.yaw_accel_radps2 == 0.2) << name;
    }
    if (!t.measure) {
      EXPECT_EQ(effect.Measure(eta.data(), m, states0.data()), 0.0) << name;
    }
    if (!t.measure_yaw_rate) {
      EXPECT_EQ(effect.MeasureYawRate(eta.data(), m, states0.data()), 0.0) << name;
    }
    if (!t.init_states) {
      std::vector<double> st = states0;
      effect.InitStates(eta.data(), p, kL, u, x, 2.0, st.data());
      EXPECT_EQ(st, states0) << name;
    }
    if (!t.advance_states) {
      std::vector<double> st = states0;
      effect.AdvanceStates(eta.data(), p, kL, u, u, x, x, 2.0, 0.02, st.data());
      EXPECT_EQ(st, states0) << name;
    }
  }
  const Effect::Terms gyro = ModelSpec::FromNames({"gyro_offset"}).effects().at(0)->terms();
  EXPECT_TRUE(gyro.inputs && gyro.measure_yaw_rate);
  EXPECT_FALSE(gyro.forces || gyro.measure || gyro.init_states || gyro.advance_states);
  const Effect::Terms bank = ModelSpec::FromNames({"road_bank"}).effects().at(0)->terms();
  EXPECT_TRUE(bank.forces && bank.init_states && bank.advance_states);
  EXPECT_FALSE(bank.inputs || bank.measure || bank.measure_yaw_rate);
}

}  // namespace
}  // namespace ndsid::model
