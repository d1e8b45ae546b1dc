// The vehicle truth against the single-track model's closed forms and its own fine-step
// reference: EG and Ackermann in steady state, RK4 step error, standstill on a crossfall, and
// the vehicle-side effects (tyre saturation, relaxation, roll mode) against their equations.
#include "ndsid/sim/vehicle_truth.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ndsid/sim/simulator.h"

namespace ndsid::sim {
namespace {

constexpr double kG = model::kGravity_mps2;

config::SimulationConfig Cmax() { return config::SimulationConfig{}; }

// Integrates constant inputs until the states settle.
TruthOutputs SettleAt(const VehicleTruth& truth, TruthState& x, const TruthInputs& u, double seconds = 20.0) {
  const double dt = 0.005;
  for (double t = 0; t < seconds; t += dt) truth.Step(x, u, u, dt);
  return truth.Outputs(x, u);
}

TEST(VehicleTruth, SteadyStateCircleReproducesSelfSteerGradient) {
  // Catches a wrong EG, a sign error in a tyre force, or the bank term leaking in.
  const auto cfg = Cmax();
  const auto p = BaseParams(cfg.vehicle);
  const double l = cfg.vehicle.wheelbase_m;
  const VehicleTruth truth(p, l, cfg.effects, cfg.integration);
  const double eg = model::SelfSteerGradient(p, l);
  EXPECT_NEAR(eg, 7.455e-3, 1e-5);
  const double radius = 60.0;  // the ISO 4138 circle of the study (60 m, 10..70 km/h)
  for (double v_kph : {10.0, 30.0, 50.0, 70.0}) {
    const double v = v_kph / 3.6;
    const double a_y = v * v / radius;
    const double steer = p.is * (l / radius + eg * a_y);  // d_sw/is = l/R + EG a_y
    TruthState x;
    const TruthOutputs o = SettleAt(truth, x, {steer, v, 0.0});
    EXPECT_NEAR(o.r, v / radius, 1e-6 * v / radius + 1e-9) << v_kph << " km/h";
    EXPECT_NEAR(o.a_y, a_y, 1e-6 * a_y + 1e-9) << v_kph << " km/h";
  }
}

TEST(VehicleTruth, LowSpeedGivesAckermannAngle) {
  // Catches a kinematic fallback that is not the model's low-speed limit or a blend with a jump.
  const auto cfg = Cmax();
  const auto p = BaseParams(cfg.vehicle);
  const double l = cfg.vehicle.wheelbase_m;
  const VehicleTruth truth(p, l, cfg.effects, cfg.integration);
  const double steer = 300.0 * M_PI / 180.0;  // parking-lot steering
  for (double v : {0.3, 1.0, 1.5, 2.0, 2.5, 3.0, 4.0}) {
    TruthState x;
    const TruthOutputs o = SettleAt(truth, x, {steer, v, 0.0});
    const double ackermann = v * steer / p.is / l;  // r = v delta / l
    const double understeer = truth.self_steer_gradient() * v * v / l;  // r = Ackermann / (1 + EG v^2/l)
    EXPECT_NEAR(o.r, ackermann, (understeer + 1e-3) * ackermann) << v << " m/s";
    EXPECT_NEAR(o.r, truth.KinematicYawRate(steer, v), 1e-3 * ackermann) << v << " m/s";
  }
  // Reversing: the yaw rate changes sign with the speed.
  TruthState x;
  const TruthOutputs o = SettleAt(truth, x, {steer, -1.0, 0.0});
  EXPECT_NEAR(o.r, -steer / p.is / l, 0.01 * steer / p.is / l);
}

TEST(VehicleTruth, StandstillOnCrossfallReadsGSinTheta) {
  // Catches the wrong sign of the crossfall on the accelerometer (ISO: theta > 0 = left edge
  // higher; tyres push uphill, to the left, so the reading is +g sin(theta)).
  const auto cfg = Cmax();
  const VehicleTruth truth(BaseParams(cfg.vehicle), cfg.vehicle.wheelbase_m, cfg.effects, cfg.integration);
  const double theta = std::atan(0.03);
  TruthState x;
  const TruthOutputs o = SettleAt(truth, x, {0.0, 0.0, theta});
  EXPECT_NEAR(o.a_y, kG * std::sin(theta), 1e-9);
  EXPECT_NEAR(o.r, 0.0, 1e-12);
  // Driving straight on it: the tyres carry the slope force, the car does not turn.
  TruthState y;
  const double v = 20.0;
  const double steer = truth.params().is * truth.self_steer_gradient() * kG * std::sin(theta);  // delta = EG g sin(theta)
  const TruthOutputs m = SettleAt(truth, y, {steer, v, theta});
  EXPECT_NEAR(m.r, 0.0, 1e-6);
  EXPECT_NEAR(m.a_y, kG * std::sin(theta), 1e-6);
}

TEST(VehicleTruth, Rk4StepErrorIsNegligibleAgainstFineReference) {
  // Catches an integration step too coarse for the stiff low-speed dynamics or for fast steering:
  // the inputs of a real simulated drive, at 200 Hz vs 2000 Hz.
  config::SimulationConfig cfg = Cmax();
  cfg.duration.drives = 1;
  cfg.seed = 11;
  const SimulationResult sim = Simulate(cfg);
  const DriveSeries& s = sim.drives[0].series;
  const VehicleTruth truth(sim.drives[0].params, cfg.vehicle.wheelbase_m, cfg.effects, cfg.integration);
  auto run = [&](int substeps) {
    std::vector<double> a_y(s.size());
    TruthState x;
    const double dt = 0.01 / substeps;
    for (size_t i = 0; i + 1 < s.size(); ++i) {
      a_y[i] = truth.Outputs(x, {s.steer_sw_rad[i], s.speed_mps[i], s.bank_rad[i]}).a_y;
      for (int k = 0; k < substeps; ++k) {
        const double f0 = static_cast<double>(k) / substeps, f1 = static_cast<double>(k + 1) / substeps;
        auto at = [&](double f) {
          return TruthInputs{s.steer_sw_rad[i] + f * (s.steer_sw_rad[i + 1] - s.steer_sw_rad[i]),
                             s.speed_mps[i] + f * (s.speed_mps[i + 1] - s.speed_mps[i]),
                             s.bank_rad[i] + f * (s.bank_rad[i + 1] - s.bank_rad[i])};
        };
        truth.Step(x, at(f0), at(f1), dt);
      }
    }
    return a_y;
  };
  const auto coarse = run(2), fine = run(20);
  double max_err = 0.0, max_ay = 0.0;
  for (size_t i = 0; i + 1 < s.size(); ++i) {
    max_err = std::max(max_err, std::fabs(coarse[i] - fine[i]));
    max_ay = std::max(max_ay, std::fabs(fine[i]));
  }
  std::printf("RK4 200 Hz vs 2000 Hz: max |a_y error| %.2e m/s^2 (max |a_y| %.2f) over %zu samples\n", max_err, max_ay,
              s.size());
  EXPECT_LT(max_err, 1e-3);  // vs 0.05 m/s^2 sensor noise and 0.01 m/s^2 DBC resolution
  EXPECT_GT(max_ay, 1.0);
}

TEST(VehicleTruth, TyreSaturationForcesFollowTanh) {
  // Catches saturation applied to the wrong axle load or a linear law left in place.
  config::SimulationConfig cfg = Cmax();
  cfg.effects.tyre_mu = 0.8;
  const auto p = BaseParams(cfg.vehicle);
  const double l = cfg.vehicle.wheelbase_m, lh = l - p.lv;
  const VehicleTruth sat(p, l, cfg.effects, cfg.integration);
  const VehicleTruth lin(p, l, config::SimEffects{}, cfg.integration);
  const double v = 20.0, steer = 70.0 * M_PI / 180.0;
  TruthState xs, xl;
  const TruthOutputs os = SettleAt(sat, xs, {steer, v, 0.0});
  const TruthOutputs ol = SettleAt(lin, xl, {steer, v, 0.0});
  EXPECT_LT(os.a_y, ol.a_y * 0.97);  // saturation: less lateral acceleration for the same steering
  // Steady state: Fh = m a_y lv / l must equal D tanh(ch alpha_h / D), D = mu m g lv / l.
  const double alpha_h = -xs.beta + lh * xs.r / v;
  const double d_rear = 0.8 * p.m * kG * p.lv / l;
  EXPECT_NEAR(p.m * os.a_y * p.lv / l, d_rear * std::tanh(p.ch * alpha_h / d_rear), 1e-3 * d_rear);
  const double alpha_v = steer / p.is - xs.beta - p.lv * xs.r / v;
  const double d_front = 0.8 * p.m * kG * lh / l;
  EXPECT_NEAR(p.m * os.a_y * lh / l, d_front * std::tanh(p.cv * alpha_v / d_front), 1e-3 * d_front);
}

TEST(VehicleTruth, RelaxationLagsSlipAngleWithTauSigmaOverV) {
  // Catches a relaxation time that does not scale with 1/v, or one that changes the steady state.
  config::SimulationConfig cfg = Cmax();
  cfg.effects.relaxation_length_m = 0.5;
  const auto p = BaseParams(cfg.vehicle);
  const double l = cfg.vehicle.wheelbase_m;
  const VehicleTruth relax(p, l, cfg.effects, cfg.integration);
  const VehicleTruth base(p, l, config::SimEffects{}, cfg.integration);
  const double v = 10.0, steer = 0.3;
  TruthState xr, xb;
  EXPECT_NEAR(SettleAt(relax, xr, {steer, v, 0.0}).a_y, SettleAt(base, xb, {steer, v, 0.0}).a_y, 1e-9);
  // Step in steering from straight running: right after it, alpha_f,lag rises as 1 - exp(-t v / sigma)
  // towards the instantaneous slip angle (beta and r barely move within tau = 50 ms).
  TruthState x;
  const double tau = 0.5 / v, dt = 0.0005;
  for (double t = 0; t < tau - 1e-12; t += dt) relax.Step(x, {steer, v, 0.0}, {steer, v, 0.0}, dt);
  const double alpha_now = steer / p.is - x.beta - p.lv * x.r / v;
  EXPECT_NEAR(x.alpha_f / alpha_now, 1.0 - std::exp(-1.0), 0.05);
}

TEST(VehicleTruth, RollModeSettlesAtGradientTimesLateralAccel) {
  // Catches a wrong roll gain unit (deg/g) or an unstable/undamped roll mode.
  config::SimulationConfig cfg = Cmax();
  cfg.effects.roll_gradient_deg_per_g = 5.0;
  const VehicleTruth truth(BaseParams(cfg.vehicle), cfg.vehicle.wheelbase_m, cfg.effects, cfg.integration);
  TruthState x;
  const TruthOutputs o = SettleAt(truth, x, {0.5, 15.0, 0.0});
  EXPECT_NEAR(o.roll, 5.0 * M_PI / 180.0 * o.a_y / kG, 1e-9);
  EXPECT_GT(o.roll, 0.0);  // left turn: body rolls right side down = + (ISO)
}

TEST(VehicleTruth, SteeringPlayAndUnequalSidesActOnTheRoadWheels) {
  // Catches on-centre play or a left/right asymmetry applied with the wrong sign, at the wrong
  // place (the measured steering instead of the road wheels), or only in one of the blended models.
  const auto cfg = Cmax();
  const auto p = BaseParams(cfg.vehicle);
  const double l = cfg.vehicle.wheelbase_m;
  const VehicleTruth plain(p, l, cfg.effects, cfg.integration);
  config::SimEffects play_fx = cfg.effects, unequal_fx = cfg.effects, lead_fx = cfg.effects;
  play_fx.steer_deadband_deg = 2.0;
  lead_fx.steer_deadband_deg = -2.0;
  unequal_fx.steer_asymmetry_pct = -4.0;
  const VehicleTruth play(p, l, play_fx, cfg.integration), unequal(p, l, unequal_fx, cfg.integration),
      lead(p, l, lead_fx, cfg.integration);
  const double b = 2.0 * M_PI / 180.0;
  EXPECT_DOUBLE_EQ(play.Linkage(0.01), 0.0);  // inside the play: the wheels stay straight
  EXPECT_DOUBLE_EQ(play.Linkage(-0.3), -0.3 + b);
  EXPECT_DOUBLE_EQ(lead.Linkage(0.01), 0.02);  // inside the lead: the wheels turn twice as far
  EXPECT_DOUBLE_EQ(lead.Linkage(-0.3), -0.3 - b);
  EXPECT_DOUBLE_EQ(unequal.Linkage(0.3), 0.3 * 0.96);
  EXPECT_DOUBLE_EQ(unequal.Linkage(-0.3), -0.3 * 1.04);
  for (double v : {2.0, 25.0}) {  // the kinematic model at walking pace, the dynamic one at speed
    for (double steer : {0.4, -0.4}) {
      TruthState x0, x1, x2, x3;
      const double with_play = SettleAt(play, x0, {steer, v, 0.0}).a_y;
      const double without = SettleAt(plain, x1, {steer - std::copysign(b, steer), v, 0.0}).a_y;
      EXPECT_NEAR(with_play, without, 1e-9 + 1e-7 * std::fabs(without)) << v << " m/s, " << steer;
      const double with_unequal = SettleAt(unequal, x2, {steer, v, 0.0}).a_y;
      const double scaled = SettleAt(plain, x3, {steer * (steer > 0 ? 0.96 : 1.04), v, 0.0}).a_y;
      EXPECT_NEAR(with_unequal, scaled, 1e-9 + 1e-7 * std::fabs(scaled)) << v << " m/s, " << steer;
    }
  }
}

// Catches: active rear steering with the wrong sign, the wrong speed law, or only in one of the
// blended models. In steady state the linear single-track model with rear steer turns as the
// plain one does with delta - delta_h: the same a_y at the same speed.
TEST(VehicleTruth, RearSteeringTurnsLikeTheFrontLessTheRear) {
  const auto cfg = Cmax();
  const auto p = BaseParams(cfg.vehicle);
  const double l = cfg.vehicle.wheelbase_m;
  const VehicleTruth plain(p, l, cfg.effects, cfg.integration);
  config::SimEffects fx = cfg.effects;
  fx.rear_steer_pct = 20.0;
  const VehicleTruth ars(p, l, fx, cfg.integration);
  EXPECT_DOUBLE_EQ(plain.RearSteer(0.3, 30.0), 0.0);
  EXPECT_NEAR(ars.RearSteer(0.3, 30.0), 0.2 * 0.75 * 0.3 / p.is, 1e-15);   // with the front at 30 m/s
  EXPECT_NEAR(ars.RearSteer(0.3, 15.0), 0.0, 1e-15);                       // crossing at 15 m/s
  EXPECT_LT(ars.RearSteer(0.3, 5.0), 0.0);                                 // against it at walking pace
  for (double v : {2.0, 10.0, 25.0}) {
    const double ratio = 0.2 * ((v / 30) * (v / 30) - 0.25);  // delta_h / delta
    for (double steer : {0.4, -0.4}) {
      TruthState x0, x1;
      const double with_ars = SettleAt(ars, x0, {steer, v, 0.0}).a_y;
      const double equivalent = SettleAt(plain, x1, {steer * (1 - ratio), v, 0.0}).a_y;
      EXPECT_NEAR(with_ars, equivalent, 1e-9 + 1e-7 * std::fabs(equivalent)) << v << " m/s, " << steer;
    }
  }
}

}  // namespace
}  // namespace ndsid::sim
