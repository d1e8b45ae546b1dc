#include "ndsid/sim/vehicle_truth.h"

#include <algorithm>
#include <cmath>

namespace ndsid::sim {

using model::kGravity_mps2;

namespace {
constexpr double kDownforceSpeed_mps = 30.0;  // rear_stiffness_speed_pct is the rise at this speed
constexpr double kRearSteerSpeed_mps = 30.0;   // rear_steer_pct: delta_h / delta at this speed, less 1/4
}  // namespace

VehicleTruth::VehicleTruth(const model::Params<double>& params, double wheelbase_m, const config::SimEffects& effects,
                           const config::SimIntegration& integration)
    : p_(params),
      l_(wheelbase_m),
      eg_(model::SelfSteerGradient(params, wheelbase_m)),
      fx_(effects),
      v_lo_(integration.kinematic_below_mps),
      v_hi_(integration.dynamic_above_mps) {
  const double lh = l_ - p_.lv;
  // Static axle loads Fz,v = m g lh/l, Fz,h = m g lv/l.
  d_front_n_ = fx_.tyre_mu * p_.m * kGravity_mps2 * lh / l_;
  d_rear_n_ = fx_.tyre_mu * p_.m * kGravity_mps2 * p_.lv / l_;
  roll_gain_rad_per_mps2_ = fx_.roll_gradient_deg_per_g * M_PI / 180.0 / kGravity_mps2;
  roll_omega_radps_ = 2.0 * M_PI * fx_.roll_frequency_hz;
}

double VehicleTruth::BlendWeight(double speed_mps) const {
  const double x = std::clamp((std::fabs(speed_mps) - v_lo_) / (v_hi_ - v_lo_), 0.0, 1.0);
  return x * x * (3.0 - 2.0 * x);
}

double VehicleTruth::Linkage(double steer_sw_rad) const {
  // Two steering properties outside the model library: on-centre free play (b > 0: the road
  // wheels follow d_sw - clip(d_sw, -b, b)) or a lead (b < 0: d_sw + clip(d_sw, -|b|, |b|)), and a
  // steering unequal left and right (d_sw (1 + k sgn d_sw)).
  const double b = fx_.steer_deadband_deg * M_PI / 180.0, c = std::fabs(b);
  const double d = steer_sw_rad - (b < 0 ? -1.0 : 1.0) * std::clamp(steer_sw_rad, -c, c);
  return d * (1.0 + 0.01 * fx_.steer_asymmetry_pct * (d > 0 ? 1.0 : d < 0 ? -1.0 : 0.0));
}

double VehicleTruth::RearSteer(double steer_sw_rad, double v) const {
  // Active rear steering outside the model library: counter-phase at low speed (agility), in
  // phase at high speed (stability), crossing at 15 m/s.
  if (fx_.rear_steer_pct == 0.0) return 0.0;
  const double x = v / kRearSteerSpeed_mps;
  return 0.01 * fx_.rear_steer_pct * (x * x - 0.25) * Linkage(steer_sw_rad) / p_.is;
}

double VehicleTruth::KinematicYawRate(double steer_sw_rad, double v) const {
  return v * (Linkage(steer_sw_rad) / p_.is - RearSteer(steer_sw_rad, v)) / (l_ + eg_ * v * v);
}

double VehicleTruth::KinematicSideSlip(double steer_sw_rad, double v) const {
  // Steady state of the linear model: beta = delta_h + (r/v) (lh - m v^2 lv / (l ch)); finite at v = 0.
  const double d_h = RearSteer(steer_sw_rad, v);
  const double r_over_v = (Linkage(steer_sw_rad) / p_.is - d_h) / (l_ + eg_ * v * v);
  return d_h + r_over_v * ((l_ - p_.lv) - p_.m * v * v * p_.lv / (l_ * p_.ch));
}

TruthState VehicleTruth::Derivative(const TruthState& x, const TruthInputs& u, TruthOutputs* out) const {
  // The dynamic model runs at v_d >= v_lo (it is stiff and singular as v -> 0); below v_hi its
  // output is blended with the kinematic model, so the floor never shows in the truth.
  const double v_d = std::max(std::fabs(u.speed_mps), v_lo_);
  const model::State<double> xs{x.beta, x.r};
  model::AxleSlip<double> slip = model::SlipAngles(p_, l_, xs, Linkage(u.steer_sw_rad), v_d);
  slip.rear += RearSteer(u.steer_sw_rad, v_d);  // alpha_h = delta_h - beta + lh r/v
  TruthState dx{};
  double a_f = slip.front, a_r = slip.rear;
  if (fx_.relaxation_length_m > 0.0) {  // alpha_l' = (alpha - alpha_l) v / sigma
    dx.alpha_f = (slip.front - x.alpha_f) * v_d / fx_.relaxation_length_m;
    dx.alpha_r = (slip.rear - x.alpha_r) * v_d / fx_.relaxation_length_m;
    a_f = x.alpha_f;
    a_r = x.alpha_r;
  }
  // Downforce (rear_stiffness_speed_pct): the rear axle stiffer with speed, an effect outside the
  // model library that the desk's signed view must show as a gain changing with speed.
  const double ch = p_.ch * (1.0 + 0.01 * fx_.rear_stiffness_speed_pct * (v_d / kDownforceSpeed_mps) * (v_d / kDownforceSpeed_mps));
  double f_front = p_.cv * a_f, f_rear = ch * a_r;
  if (fx_.tyre_mu > 0.0) {  // F = D tanh(c alpha / D)
    f_front = d_front_n_ * std::tanh(f_front / d_front_n_);
    f_rear = d_rear_n_ * std::tanh(f_rear / d_rear_n_);
  }
  const model::Derivative<double> d = model::DerivativeFromForces(p_, l_, xs, v_d, f_front, f_rear);
  // Road bank: gravity's body-y component -g sin(theta) acts on the mass but not on the
  // accelerometer's reading (tyre forces / m): beta' = (F/m - g sin theta)/v - r.
  const double g_bank = kGravity_mps2 * std::sin(u.bank_rad);
  dx.beta = d.beta_dot - g_bank / v_d;
  dx.r = d.r_dot;

  const double w = BlendWeight(u.speed_mps);
  const double r_kin = KinematicYawRate(u.steer_sw_rad, u.speed_mps);
  const double a_y = w * d.a_y + (1.0 - w) * (u.speed_mps * r_kin + g_bank);
  if (fx_.roll_on()) {  // phi'' = w0^2 (k_phi a_y - phi) - 2 zeta w0 phi'
    dx.roll = x.roll_rate;
    dx.roll_rate = roll_omega_radps_ * roll_omega_radps_ * (roll_gain_rad_per_mps2_ * a_y - x.roll) -
                   2.0 * fx_.roll_damping_ratio * roll_omega_radps_ * x.roll_rate;
  }
  if (out) {
    out->blend = w;
    out->beta = w * x.beta + (1.0 - w) * KinematicSideSlip(u.steer_sw_rad, u.speed_mps);
    out->r = w * x.r + (1.0 - w) * r_kin;
    out->a_y = a_y;
    out->r_dot_dyn = d.r_dot;
    out->roll = x.roll;
  }
  return dx;
}

TruthOutputs VehicleTruth::Outputs(const TruthState& x, const TruthInputs& u) const {
  TruthOutputs out;
  Derivative(x, u, &out);
  return out;
}

namespace {
TruthState Add(const TruthState& x, const TruthState& d, double h) {
  return {x.beta + h * d.beta, x.r + h * d.r, x.alpha_f + h * d.alpha_f, x.alpha_r + h * d.alpha_r,
          x.roll + h * d.roll, x.roll_rate + h * d.roll_rate};
}
TruthInputs Mid(const TruthInputs& a, const TruthInputs& b) {
  return {0.5 * (a.steer_sw_rad + b.steer_sw_rad), 0.5 * (a.speed_mps + b.speed_mps), 0.5 * (a.bank_rad + b.bank_rad)};
}
}  // namespace

void VehicleTruth::Step(TruthState& x, const TruthInputs& u0, const TruthInputs& u1, double dt) const {
  const TruthInputs um = Mid(u0, u1);
  const TruthState k1 = Derivative(x, u0, nullptr);
  const TruthState k2 = Derivative(Add(x, k1, 0.5 * dt), um, nullptr);
  const TruthState k3 = Derivative(Add(x, k2, 0.5 * dt), um, nullptr);
  const TruthState k4 = Derivative(Add(x, k3, dt), u1, nullptr);
  const double h = dt / 6.0;
  x.beta += h * (k1.beta + 2.0 * k2.beta + 2.0 * k3.beta + k4.beta);
  x.r += h * (k1.r + 2.0 * k2.r + 2.0 * k3.r + k4.r);
  x.alpha_f += h * (k1.alpha_f + 2.0 * k2.alpha_f + 2.0 * k3.alpha_f + k4.alpha_f);
  x.alpha_r += h * (k1.alpha_r + 2.0 * k2.alpha_r + 2.0 * k3.alpha_r + k4.alpha_r);
  x.roll += h * (k1.roll + 2.0 * k2.roll + 2.0 * k3.roll + k4.roll);
  x.roll_rate += h * (k1.roll_rate + 2.0 * k2.roll_rate + 2.0 * k3.roll_rate + k4.roll_rate);
}

}  // namespace ndsid::sim
