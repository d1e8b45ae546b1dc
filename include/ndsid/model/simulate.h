// Output-error simulation of the single-track model over one stretch of measured inputs:
// the one loop the identifier (with Ceres Jets), the comparison tools and the tests share.
#pragma once

#include <cstddef>

#include "ndsid/model/single_track.h"

namespace ndsid::model {

// Steady state of the linear model for constant inputs (beta' = r' = 0): the initial state
// of every simulated stretch, so the burn-in only has to absorb the deviation from it.
template <typename T>
State<T> SteadyState(const Params<T>& p, double l, double steer_wheel_rad, double v_mps) {
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

// Simulates n samples spaced dt apart, starting from the steady state of the first input, and
// writes the modelled lateral acceleration at each sample time to a_y_out[0..n).
// Inputs are read through accessor functors steer(k) [rad] and speed(k) [m/s].
template <typename T, typename SteerFn, typename SpeedFn>
void SimulateLateralAcceleration(const Params<T>& p, double wheelbase_m, double dt_s, size_t n, SteerFn steer,
                                 SpeedFn speed, T* a_y_out) {
  if (n == 0) return;
  State<T> x = SteadyState(p, wheelbase_m, steer(0), speed(0));
  for (size_t k = 0; k + 1 < n; ++k) {
    a_y_out[k] = Rk4Step(p, wheelbase_m, x, steer(k), steer(k + 1), speed(k), speed(k + 1), dt_s);
  }
  a_y_out[n - 1] = LinearDerivative(p, wheelbase_m, x, steer(n - 1), speed(n - 1)).a_y;
}

}  // namespace ndsid::model
