// The linear single-track (bicycle) model of docs/physics.md §1, written once and
// templated on the scalar type so the simulator, the identifier (Ceres autodiff Jets), the
// diagnosis and the tests all call the same equations. SI units, ISO 8855 signs.
#pragma once

#include <cmath>

namespace ndsid::model {

inline constexpr double kGravity_mps2 = 9.81;

// The six parameters p = (m, Jz, cv, ch, lv, is) in the order the identifier uses.
enum ParamIndex { kMass = 0, kYawInertia, kStiffFront, kStiffRear, kCgToFront, kSteerRatio, kNumParams };
inline constexpr const char* kParamNames[kNumParams] = {"m", "Jz", "cv", "ch", "lv", "is"};
inline constexpr const char* kParamUnits[kNumParams] = {"kg", "kg m^2", "N/rad", "N/rad", "m", "-"};

template <typename T>
struct Params {
  T m;   // mass [kg]
  T Jz;  // yaw moment of inertia [kg m^2]
  T cv;  // front axle cornering stiffness [N/rad]
  T ch;  // rear axle cornering stiffness [N/rad]
  T lv;  // CG to front axle [m]
  T is;  // steering ratio, steering-wheel angle / road-wheel angle [-]

  static Params FromArray(const T* p) { return {p[0], p[1], p[2], p[3], p[4], p[5]}; }
};

template <typename T>
struct State {
  T beta;  // body side-slip angle [rad]
  T r;     // yaw rate [rad/s]
};

template <typename T>
struct Derivative {
  T beta_dot;  // [rad/s]
  T r_dot;     // [rad/s^2]
  T a_y;       // lateral acceleration of the CG = what a body-fixed accelerometer there reads [m/s^2]
};

// Front and rear axle side forces for linear tyres; the slip angles are exposed so effects
// (saturation, relaxation) can be layered on top.
template <typename T>
struct AxleSlip {
  T front;  // a_v [rad]
  T rear;   // a_h [rad]
};

template <typename T, typename U>
AxleSlip<T> SlipAngles(const Params<T>& p, double wheelbase_m, const State<T>& x, const U& steer_wheel_rad,
                       const U& speed_mps) {
  const T lh = T(wheelbase_m) - p.lv;
  const T delta = T(steer_wheel_rad) / p.is;  // road-wheel angle
  return {delta - x.beta - p.lv * x.r / T(speed_mps), -x.beta + lh * x.r / T(speed_mps)};
}

// beta' = (Fv + Fh)/(m v) - r ;  r' = (lv Fv - lh Fh)/Jz ;  a_y = (Fv + Fh)/m
// Given axle side forces (linear: F = c*alpha; effects may pass others).
template <typename T, typename U>
Derivative<T> DerivativeFromForces(const Params<T>& p, double wheelbase_m, const State<T>& x,
                                   const U& speed_mps, const T& force_front_n, const T& force_rear_n) {
  const T lh = T(wheelbase_m) - p.lv;
  const T a_y = (force_front_n + force_rear_n) / p.m;
  return {a_y / T(speed_mps) - x.r, (p.lv * force_front_n - lh * force_rear_n) / p.Jz, a_y};
}

template <typename T, typename U>
Derivative<T> LinearDerivative(const Params<T>& p, double wheelbase_m, const State<T>& x, const U& steer_wheel_rad,
                               const U& speed_mps) {
  const AxleSlip<T> slip = SlipAngles(p, wheelbase_m, x, steer_wheel_rad, speed_mps);
  return DerivativeFromForces(p, wheelbase_m, x, speed_mps, p.cv * slip.front, p.ch * slip.rear);
}

// One classic Runge-Kutta step of the linear model over dt with inputs interpolated linearly
// between (steer0, v0) at the start and (steer1, v1) at the end. Returns a_y at the step's start.
template <typename T>
T Rk4Step(const Params<T>& p, double wheelbase_m, State<T>& x, double steer0_rad, double steer1_rad, double v0_mps,
          double v1_mps, double dt_s) {
  const double steer_mid = 0.5 * (steer0_rad + steer1_rad);
  const double v_mid = 0.5 * (v0_mps + v1_mps);
  const Derivative<T> k1 = LinearDerivative(p, wheelbase_m, x, steer0_rad, v0_mps);
  const State<T> x2{x.beta + T(0.5 * dt_s) * k1.beta_dot, x.r + T(0.5 * dt_s) * k1.r_dot};
  const Derivative<T> k2 = LinearDerivative(p, wheelbase_m, x2, steer_mid, v_mid);
  const State<T> x3{x.beta + T(0.5 * dt_s) * k2.beta_dot, x.r + T(0.5 * dt_s) * k2.r_dot};
  const Derivative<T> k3 = LinearDerivative(p, wheelbase_m, x3, steer_mid, v_mid);
  const State<T> x4{x.beta + T(dt_s) * k3.beta_dot, x.r + T(dt_s) * k3.r_dot};
  const Derivative<T> k4 = LinearDerivative(p, wheelbase_m, x4, steer1_rad, v1_mps);
  x.beta += T(dt_s / 6.0) * (k1.beta_dot + T(2.0) * k2.beta_dot + T(2.0) * k3.beta_dot + k4.beta_dot);
  x.r += T(dt_s / 6.0) * (k1.r_dot + T(2.0) * k2.r_dot + T(2.0) * k3.r_dot + k4.r_dot);
  return k1.a_y;
}

// Self-steering (understeer) gradient EG = m/l * (lh*ch - lv*cv)/(cv*ch)  [rad/(m/s^2)]
template <typename T>
T SelfSteerGradient(const Params<T>& p, double wheelbase_m) {
  const T lh = T(wheelbase_m) - p.lv;
  return p.m / T(wheelbase_m) * (lh * p.ch - p.lv * p.cv) / (p.cv * p.ch);
}

// rad/(m/s^2) -> deg/g, the unit vehicle-dynamics engineers quote.
inline double EgToDegPerG(double eg_rad_per_mps2) { return eg_rad_per_mps2 * 180.0 / M_PI * kGravity_mps2; }

// Steady state: d_sw/is = l*r/v + EG*a_y with a_y = v*r, so r = v*delta/(l + EG v^2).
inline double SteadyStateYawRate(const Params<double>& p, double wheelbase_m, double steer_wheel_rad,
                                 double speed_mps) {
  const double eg = SelfSteerGradient(p, wheelbase_m);
  return speed_mps * (steer_wheel_rad / p.is) / (wheelbase_m + eg * speed_mps * speed_mps);
}

}  // namespace ndsid::model
