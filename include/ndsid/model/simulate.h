// Output-error simulation of the model over one stretch of measured inputs: the one loop the
// identifier (with Ceres Jets), the comparison and diagnosis tools and the tests share.
#pragma once

#include <cstddef>
#include <vector>

#include "ndsid/model/model_spec.h"
#include "ndsid/model/single_track.h"

namespace ndsid::model {

// Steady state of the linear model for constant inputs (beta' = r' = 0): the initial state
// of every simulated stretch, so the burn-in only has to absorb the deviation from it.
template <typename T, typename U>
State<T> SteadyState(const Params<T>& p, double l, const U& steer_wheel_rad, const U& v_mps) {
  // Linear system A x = -b delta with x = (beta, r):
  //   beta' = -(cv+ch)/(m v) beta + ((ch lh - cv lv)/(m v^2) - 1) r + cv/(m v) delta
  //   r'    = (ch lh - cv lv)/Jz beta - (cv lv^2 + ch lh^2)/(Jz v) r + cv lv/Jz delta
  const T lh = T(l) - p.lv;
  const T v(v_mps);
  const T delta = T(steer_wheel_rad) / p.is;
  const T a11 = -(p.cv + p.ch) / (p.m * v);
  const T a12 = (p.ch * lh - p.cv * p.lv) / (p.m * v * v) - T(1.0);
  const T a21 = (p.ch * lh - p.cv * p.lv) / p.Jz;
  const T a22 = -(p.cv * p.lv * p.lv + p.ch * lh * lh) / (p.Jz * v);
  const T b1 = p.cv / (p.m * v) * delta;
  const T b2 = p.cv * p.lv / p.Jz * delta;
  const T det = a11 * a22 - a12 * a21;
  return {(-b1 * a22 + b2 * a12) / det, (-a11 * b2 + a21 * b1) / det};
}

// Optional per-sample traces of a simulation (for comparison reports and monitoring).
struct SimulationTrace {
  std::vector<double> yaw_rate_radps;       // the model's state r (before measurement effects)
  std::vector<double> a_y_cg_mps2;          // before measurement effects
  std::vector<double> yaw_rate_meas_radps;  // the modelled *measured* yaw rate (r + effects' terms)
  std::vector<double> effect_states;        // row-major n x spec.num_states() (e.g. road_bank's b)
};

// The full model (base + effects). `params` holds the base six then every effect's parameters
// (ModelSpec layout). Writes the modelled *measured* lateral acceleration to a_meas_out[0..n)
// and, when r_meas_out is given, the modelled *measured* yaw rate (r + the effects' yaw-rate
// measurement terms) to r_meas_out[0..n): the two outputs of the fit.
template <typename T>
void SimulateModel(const ModelSpec& spec, const T* params, double l, const InputSeries& in, T* a_meas_out,
                   SimulationTrace* trace = nullptr, T* r_meas_out = nullptr) {
  const size_t n = in.n;
  if (n == 0) return;
  const Params<T> p = Params<T>::FromArray(params);
  const auto& effects = spec.effects();
  const size_t ne = effects.size();
  std::vector<Effect::Terms> terms(ne);  // the terms each effect has (a default adds nothing)
  for (size_t e = 0; e < ne; ++e) terms[e] = effects[e]->terms();
  std::vector<T> states(static_cast<size_t>(spec.num_states()), T(0.0));
  auto eta = [&](size_t e) { return params + spec.param_offset(e); };
  auto st = [&](size_t e) { return states.data() + spec.state_offset(e); };

  auto inputs_at = [&](size_t k) {
    ModelInputs<T> u{T(in.steer(k)), T(in.speed(k)), T(in.bank(k)), T(in.yaw_rate(k)), in.yaw_rate_radps != nullptr};
    for (size_t e = 0; e < ne; ++e) if (terms[e].inputs) effects[e]->Inputs(eta(e), in, k, u);
    return u;
  };
  // The base model's equations (single_track.h: SlipAngles, DerivativeFromForces) with what
  // does not change along the stretch taken out of the loop: the parameters' reciprocals and
  // lh once, and at each input point (three per step, k2 and k3 share the midpoint) 1/v and the
  // road-wheel angle. Divisions become multiplications by reciprocals (equal to the divisions
  // within a unit in the last place); a Jet division costs a multiplication's work plus a scalar
  // division that every following term waits on, and the loop had 28 of them per step.
  const T lh = T(l) - p.lv;
  const T inv_is = T(1.0) / p.is, inv_m = T(1.0) / p.m, inv_jz = T(1.0) / p.Jz;
  struct AtInputs {
    T inv_speed;  // 1 / v
    T delta;      // road-wheel angle d_sw / is
  };
  auto at_inputs = [&](const ModelInputs<T>& u) { return AtInputs{T(1.0) / u.speed_mps, u.steer_rad * inv_is}; };
  auto derivative = [&](const State<T>& x, const ModelInputs<T>& u, const AtInputs& a) {
    const T r_by_v = x.r * a.inv_speed;
    const AxleSlip<T> slip{a.delta - x.beta - p.lv * r_by_v, lh * r_by_v - x.beta};
    ForceTerms<T> f{p.cv * slip.front, p.ch * slip.rear, T(0.0), T(0.0)};
    for (size_t e = 0; e < ne; ++e) if (terms[e].forces) effects[e]->Forces(eta(e), p, l, slip, x, u, st(e), f);
    const T a_y = (f.force_front_n + f.force_rear_n) * inv_m;
    // beta' = (a_y + gravity) / v - r ;  r' = (lv Fv - lh Fh) / Jz + yaw moment / Jz
    return Derivative<T>{(a_y + f.gravity_lat_mps2) * a.inv_speed - x.r,
                         (p.lv * f.force_front_n - lh * f.force_rear_n) * inv_jz + f.yaw_accel_radps2, a_y};
  };
  auto measure = [&](const Derivative<T>& d, const State<T>& x, const ModelInputs<T>& u) {
    T a = d.a_y;
    const MeasurementContext<T> m{d.a_y, d.r_dot, x.r, u.speed_mps, &x, &u, &p, l};
    for (size_t e = 0; e < ne; ++e) if (terms[e].measure) a += effects[e]->Measure(eta(e), m, st(e));
    return a;
  };
  auto measure_yaw_rate = [&](const Derivative<T>& d, const State<T>& x, const ModelInputs<T>& u) {
    T r = x.r;
    const MeasurementContext<T> m{d.a_y, d.r_dot, x.r, u.speed_mps, &x, &u, &p, l};
    for (size_t e = 0; e < ne; ++e) if (terms[e].measure_yaw_rate) r += effects[e]->MeasureYawRate(eta(e), m, st(e));
    return r;
  };

  ModelInputs<T> u0 = inputs_at(0);
  State<T> x = SteadyState(p, l, u0.steer_rad, u0.speed_mps);
  {
    const Derivative<T> d0 = derivative(x, u0, at_inputs(u0));
    for (size_t e = 0; e < ne; ++e) if (terms[e].init_states) effects[e]->InitStates(eta(e), p, l, u0, x, d0.a_y, st(e));
  }
  const size_t ns = static_cast<size_t>(spec.num_states());
  if (trace) {
    trace->yaw_rate_radps.resize(n);
    trace->a_y_cg_mps2.resize(n);
    trace->yaw_rate_meas_radps.resize(n);
    trace->effect_states.resize(n * ns);
  }
  // Constants enter as doubles: a Jet times a double is the Jet times the constant Jet to the
  // last bit (for finite values), at a fraction of the work.
  const double half = 0.5 * in.dt_s, full = in.dt_s, sixth = in.dt_s / 6.0;
  AtInputs a0 = at_inputs(u0);
  for (size_t k = 0; k < n; ++k) {
    const Derivative<T> k1 = derivative(x, u0, a0);
    a_meas_out[k] = measure(k1, x, u0);
    if (r_meas_out || trace) {
      const T r_meas = measure_yaw_rate(k1, x, u0);
      if (r_meas_out) r_meas_out[k] = r_meas;
      if (trace) trace->yaw_rate_meas_radps[k] = ScalarOf(r_meas);
    }
    if (trace) {
      trace->yaw_rate_radps[k] = ScalarOf(x.r);
      trace->a_y_cg_mps2[k] = ScalarOf(k1.a_y);
      for (size_t j = 0; j < ns; ++j) trace->effect_states[k * ns + j] = ScalarOf(states[j]);
    }
    if (k + 1 == n) break;
    const ModelInputs<T> u1 = inputs_at(k + 1);
    const ModelInputs<T> um{(u0.steer_rad + u1.steer_rad) * 0.5, (u0.speed_mps + u1.speed_mps) * 0.5,
                            (u0.bank_mps2 + u1.bank_mps2) * 0.5, (u0.yaw_rate_meas_radps + u1.yaw_rate_meas_radps) * 0.5,
                            u0.yaw_rate_measured};
    const AtInputs am = at_inputs(um), a1 = at_inputs(u1);
    const Derivative<T> k2 = derivative({x.beta + k1.beta_dot * half, x.r + k1.r_dot * half}, um, am);
    const Derivative<T> k3 = derivative({x.beta + k2.beta_dot * half, x.r + k2.r_dot * half}, um, am);
    const Derivative<T> k4 = derivative({x.beta + k3.beta_dot * full, x.r + k3.r_dot * full}, u1, a1);
    const State<T> x1{x.beta + (k1.beta_dot + k2.beta_dot * 2.0 + k3.beta_dot * 2.0 + k4.beta_dot) * sixth,
                      x.r + (k1.r_dot + k2.r_dot * 2.0 + k3.r_dot * 2.0 + k4.r_dot) * sixth};
    for (size_t e = 0; e < ne; ++e) if (terms[e].advance_states) effects[e]->AdvanceStates(eta(e), p, l, u0, u1, x, x1, k1.a_y, in.dt_s, st(e));
    x = x1;
    u0 = u1;
    a0 = a1;
  }
}

}  // namespace ndsid::model
