// The simulated vehicle: the base single-track model of include/ndsid/model/single_track.h
// (SlipAngles + DerivativeFromForces, not retyped) plus the switchable vehicle-side effects:
// road bank as a force, tyre saturation, tyre relaxation and the body's roll mode. Integrated
// with classic RK4; below a few m/s the output blends smoothly into the kinematic model.
#pragma once

#include "ndsid/config/simulation_config.h"
#include "ndsid/model/single_track.h"

namespace ndsid::sim {

// States of the dynamic part. alpha_* are the lagged slip angles (used only with relaxation).
struct TruthState {
  double beta = 0.0;       // body side-slip of the dynamic model [rad]
  double r = 0.0;          // yaw rate of the dynamic model [rad/s]
  double alpha_f = 0.0;    // lagged front slip angle [rad]
  double alpha_r = 0.0;    // lagged rear slip angle [rad]
  double roll = 0.0;       // body roll relative to the road, ISO (+: right side down) [rad]
  double roll_rate = 0.0;  // [rad/s]
};

struct TruthInputs {
  double steer_sw_rad = 0.0;  // steering-wheel angle, + left
  double speed_mps = 0.0;     // signed: negative when reversing
  double bank_rad = 0.0;      // ISO roll angle of the road surface (+: left edge higher)
};

// The blended truth at one instant.
struct TruthOutputs {
  double beta = 0.0;         // [rad]
  double r = 0.0;            // [rad/s]
  double a_y = 0.0;          // tyre side forces / m = what an accelerometer at the CG reads [m/s^2]
  double r_dot_dyn = 0.0;    // yaw acceleration of the dynamic model [rad/s^2]
  double blend = 1.0;        // 1 = single-track model, 0 = kinematic
  double roll = 0.0;         // [rad]
};

class VehicleTruth {
 public:
  // `params` may differ per drive (mass change); wheelbase from the config.
  VehicleTruth(const model::Params<double>& params, double wheelbase_m, const config::SimEffects& effects,
               const config::SimIntegration& integration);

  // One RK4 step over dt, inputs interpolated linearly between u0 (start) and u1 (end).
  void Step(TruthState& x, const TruthInputs& u0, const TruthInputs& u1, double dt_s) const;

  // Derivative of the dynamic states; `out` receives the blended outputs at (x, u).
  TruthState Derivative(const TruthState& x, const TruthInputs& u, TruthOutputs* out) const;
  TruthOutputs Outputs(const TruthState& x, const TruthInputs& u) const;

  // The steering-wheel angle the road wheels follow (steer_deadband_deg, steer_asymmetry_pct;
  // d_sw itself without them). Every use of the steering below goes through it.
  double Linkage(double steer_sw_rad) const;
  // The rear axle's steering angle (rear_steer_pct; 0 without it) at the road wheels, positive
  // with the front's: against it below 15 m/s, with it above.
  double RearSteer(double steer_sw_rad, double speed_mps) const;
  // Kinematic limit (steady state of the linear model): r = v*(delta - delta_h)/(l + EG v^2).
  double KinematicYawRate(double steer_sw_rad, double speed_mps) const;
  double KinematicSideSlip(double steer_sw_rad, double speed_mps) const;
  // Smoothstep weight of the dynamic model, 0 below kinematic_below_mps, 1 above dynamic_above_mps.
  double BlendWeight(double speed_mps) const;

  const model::Params<double>& params() const { return p_; }
  double wheelbase_m() const { return l_; }
  double self_steer_gradient() const { return eg_; }  // EG [rad/(m/s^2)]

 private:
  model::Params<double> p_;
  double l_;
  double eg_;
  config::SimEffects fx_;
  double v_lo_, v_hi_;
  double d_front_n_, d_rear_n_;  // tyre saturation force mu*Fz per axle
  double roll_gain_rad_per_mps2_, roll_omega_radps_;
};

}  // namespace ndsid::sim
