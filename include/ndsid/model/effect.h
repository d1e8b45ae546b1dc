// A physical effect the base single-track model leaves out (physics.md §4), as a model
// component: named parameters (bounds, initial value, unit) and a term in the inputs, the
// dynamics or the measurement equation. Written once as templates in a class deriving from
// EffectImpl<Derived>; the adapter instantiates them for double and for the autodiff Jet, so
// the simulator of the model, the identifier (Ceres) and the diagnosis all use the same code.
//
// The model stage uses Ceres' Jet header only, as the autodiff scalar type; the solver itself
// stays in the identify stage.
#pragma once

#include <ceres/jet.h>

#include <memory>
#include <string>
#include <type_traits>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/model/single_track.h"

namespace ndsid::model {

// Autodiff Jets. The fit computes a chunk's derivatives a Jet's width at a time (Ceres'
// DynamicAutoDiffCostFunction stride): a model of at most kSmallJetSize parameters (the base six
// and up to two effect parameters) in one pass of the narrower SmallJet, every other model in
// passes of Jet. Each Jet operation costs in proportion to the width, and both give the same
// derivatives (each direction is computed on its own).
inline constexpr int kJetSize = 10;  // base 6 + up to 4 effect parameters per autodiff pass
inline constexpr int kSmallJetSize = 8;
using Jet = ceres::Jet<double, kJetSize>;
using SmallJet = ceres::Jet<double, kSmallJetSize>;

inline double ScalarOf(double v) { return v; }
template <int N>
double ScalarOf(const ceres::Jet<double, N>& v) { return v.a; }

struct EffectParam {
  std::string name;   // unique within the model, e.g. "steer_offset_rad"
  std::string unit;
  double lower = 0, upper = 0;
  double initial = 0;    // start of the fit
  double neutral = 0;    // value at which the effect vanishes (the base model)
  double typical = 0;    // a realistic magnitude, for probes and documentation
  // A per-drive parameter (physics.md §4 "per drive": a load, a sensor re-zeroed at every
  // ignition): each drive has its own value. The parameter vector's slot holds the reference
  // drive's value (the first training drive); the identifier estimates the others per drive
  // and carries them as identify::DriveValue (Identifier::Identify).
  bool per_drive = false;
  // The common mode of a per-drive parameter, when one exists: a factor c on every drive's
  // value is exactly the base parameters listed here scaled by c^power (a load ratio: cv and ch
  // by 1/c). Such a parameter is not determined on the reference drive: its slot stays at the
  // neutral value, and the identifier moves the common mode into these parameters.
  struct Power {
    int base_param;  // index into the base six (single_track.h)
    double power;
  };
  std::vector<Power> common_mode{};
  bool pinned_at_reference() const { return per_drive && !common_mode.empty(); }
};

struct EffectInfo {
  std::string name;          // key in configuration and on the command line
  std::string description;   // the equation, in words
  std::string signature;     // what its absence leaves in the residual
  std::vector<EffectParam> params;
  int num_states = 0;        // extra states carried between samples
  // Acts only through the yaw-rate measurement (and what reads the measured yaw rate, road_bank's
  // observer): gyro_offset, gyro_scale. A default candidate of the a_y-only diagnosis only when
  // the model has an effect that reads the measured yaw rate (below): otherwise a_y cannot see it.
  bool yaw_rate_sensor = false;
  // Reads the measured yaw rate as an input (road_bank's observer): a gyro error reaches a_y
  // through it, so the yaw-rate sensor effects are candidates even when a_y alone is fitted.
  bool reads_measured_yaw_rate = false;
  // Identifiable only with the yaw rate as an output (accel_scale: from a_y alone it trades with
  // is). Not a default candidate of the a_y-only diagnosis either.
  bool needs_yaw_rate_output = false;
  // Scored by the diagnosis without being asked for (--candidates): false for an effect whose
  // quantity step 0 already estimates (speed_delay: the speed's latency).
  bool default_candidate = true;
};

// Measured inputs of one stretch, read at fractional sample positions (for time shifts).
struct InputSeries {
  const float* steer_rad;   // d_sw as measured, element k at steer_rad[k * stride]
  const float* speed_mps;   // v as measured
  size_t stride;            // floats between consecutive samples
  size_t n;
  double dt_s;
  // Road bank seen from the data, g*sin(theta) ~ low-pass(v r - a_y,meas) [m/s^2], one float
  // per sample (nullptr when the bus has no yaw rate). Used by the road_bank effect.
  const float* bank_mps2 = nullptr;
  // Measured yaw rate [rad/s], element k at yaw_rate_radps[k * stride] (nullptr when the bus
  // has none). Used by the road_bank effect's observer.
  const float* yaw_rate_radps = nullptr;
  double steer(size_t k) const { return steer_rad[k * stride]; }
  double yaw_rate(size_t k) const { return yaw_rate_radps ? yaw_rate_radps[k * stride] : 0.0; }
  double speed(size_t k) const { return speed_mps[k * stride]; }
  double bank(size_t k) const { return bank_mps2 ? bank_mps2[k] : 0.0; }
  template <typename T>
  T Steer(const T& index) const { return Lerp(steer_rad, index); }
  template <typename T>
  T Speed(const T& index) const { return Lerp(speed_mps, index); }
  template <typename T>
  T YawRate(const T& index) const { return yaw_rate_radps ? Lerp(yaw_rate_radps, index) : T(0.0); }

 private:
  template <typename T>
  T Lerp(const float* x, const T& index) const {
    double i0 = std::floor(ScalarOf(index));
    if (i0 < 0) i0 = 0;
    if (i0 > static_cast<double>(n) - 2) i0 = static_cast<double>(n) - 2;
    const size_t i = static_cast<size_t>(i0);
    const T w = index - T(i0);
    const double a = x[i * stride], b = x[(i + 1) * stride];
    return T(a) + w * T(b - a);
  }
};

// The modelled inputs at sample k after input effects: what the vehicle "really" saw.
template <typename T>
struct ModelInputs {
  T steer_rad;
  T speed_mps;
  T bank_mps2;  // road bank estimate from the data (0 when unknown); see InputSeries
  T yaw_rate_meas_radps = T(0.0);  // measured yaw rate (0 when unknown); see InputSeries
  bool yaw_rate_measured = false;  // whether yaw_rate_meas_radps holds a measurement
};

// What the dynamics hook may change: axle forces, and an extra lateral acceleration on the
// body that the accelerometer does not sense (gravity on a banked road).
template <typename T>
struct ForceTerms {
  T force_front_n;
  T force_rear_n;
  T gravity_lat_mps2;  // enters beta' only
  T yaw_accel_radps2;  // added to r' (a yaw moment / Jz)
};

// The measured lateral acceleration the model predicts = a_y + sum of measurement terms.
template <typename T>
struct MeasurementContext {
  T a_y;        // modelled CG lateral acceleration (tyre forces / m)
  T yaw_accel;  // r'
  T yaw_rate;   // r
  T speed_mps;
  // The whole sample, for effects that read more (formula effects): set by SimulateModel; null
  // where a caller evaluates a term on its own.
  const State<T>* state = nullptr;
  const ModelInputs<T>* inputs = nullptr;
  const Params<T>* params = nullptr;
  double wheelbase_m = 0;
};

// The terms of an effect for one scalar type T (double, Jet, SmallJet): declared pure in Effect,
// forwarded to the templates in EffectImpl.
#define NDSID_EFFECT_TERMS(T)                                                                          \
  virtual void Inputs(const T* eta, const InputSeries& s, size_t k, ModelInputs<T>& u) const = 0;           \
  virtual void Forces(const T* eta, const Params<T>& p, double l, const AxleSlip<T>& slip, const State<T>& x, \
                      const ModelInputs<T>& u, const T* states, ForceTerms<T>& f) const = 0;                  \
  virtual T Measure(const T* eta, const MeasurementContext<T>& m, const T* states) const = 0;               \
  virtual T MeasureYawRate(const T* eta, const MeasurementContext<T>& m, const T* states) const = 0;        \
  virtual void InitStates(const T* eta, const Params<T>& p, double l, const ModelInputs<T>& u, const State<T>& x, \
                          T a_y, T* states) const = 0;                                                       \
  virtual void AdvanceStates(const T* eta, const Params<T>& p, double l, const ModelInputs<T>& u0,          \
                             const ModelInputs<T>& u1, const State<T>& x0, const State<T>& x1, T a_y0, double dt, \
                             T* states) const = 0;

class Effect {
 public:
  virtual ~Effect() = default;
  virtual const EffectInfo& info() const = 0;

  // For each scalar type:
  // - Inputs: sample k of the measured series -> modelled inputs (in place; effects in order).
  // - Forces (dynamics): slips are the linear-model slip angles; effect states are held over the step.
  // - Measure: returns the term added to the measured a_y.
  // - MeasureYawRate: returns the term added to the measured yaw rate r_meas = r + ... (the
  //   second output of a two-output fit; gyro_offset, gyro_scale).
  // - InitStates, AdvanceStates: initialise the effect's states at the first sample, advance them
  //   by dt after each step.
  NDSID_EFFECT_TERMS(double)
  NDSID_EFFECT_TERMS(Jet)
  NDSID_EFFECT_TERMS(SmallJet)

  // Which of the terms above the effect has: EffectImpl marks those its Derived defines, and
  // SimulateModel calls only them (a default adds nothing, yet costs a virtual call and, for a
  // Jet, a zero Jet added, at every stage of every step).
  struct Terms {
    bool inputs = true, forces = true, measure = true, measure_yaw_rate = true, init_states = true, advance_states = true;
  };
  const Terms& terms() const { return terms_; }

 protected:
  Terms terms_;
};

// CRTP adapter: Derived implements any of the templates below (the defaults do nothing):
//   template <class T> void InputsT(const T* eta, const InputSeries&, size_t k, ModelInputs<T>&) const;
//   template <class T> void ForcesT(const T* eta, const Params<T>&, double l, const AxleSlip<T>&,
//                                   const State<T>&, const ModelInputs<T>&, const T* states, ForceTerms<T>&) const;
//   template <class T> T MeasureT(const T* eta, const MeasurementContext<T>&, const T* states) const;
//   template <class T> T MeasureYawRateT(const T* eta, const MeasurementContext<T>&, const T* states) const;
//   template <class T> void InitStatesT(...), AdvanceStatesT(...)
template <class Derived>
class EffectImpl : public Effect {
 public:
  const EffectInfo& info() const override { return info_; }

#define NDSID_EFFECT_FORWARD(T)                                                                                \
  void Inputs(const T* e, const InputSeries& s, size_t k, ModelInputs<T>& u) const override {               \
    self().InputsT(e, s, k, u);                                                                              \
  }                                                                                                          \
  void Forces(const T* e, const Params<T>& p, double l, const AxleSlip<T>& sl, const State<T>& x,             \
              const ModelInputs<T>& u, const T* st, ForceTerms<T>& f) const override {                        \
    self().ForcesT(e, p, l, sl, x, u, st, f);                                                                \
  }                                                                                                          \
  T Measure(const T* e, const MeasurementContext<T>& m, const T* st) const override { return self().MeasureT(e, m, st); } \
  T MeasureYawRate(const T* e, const MeasurementContext<T>& m, const T* st) const override {                  \
    return self().MeasureYawRateT(e, m, st);                                                                 \
  }                                                                                                          \
  void InitStates(const T* e, const Params<T>& p, double l, const ModelInputs<T>& u, const State<T>& x, T a_y, \
                  T* st) const override {                                                                    \
    self().InitStatesT(e, p, l, u, x, a_y, st);                                                              \
  }                                                                                                          \
  void AdvanceStates(const T* e, const Params<T>& p, double l, const ModelInputs<T>& u0, const ModelInputs<T>& u1, \
                     const State<T>& x0, const State<T>& x1, T a_y0, double dt, T* st) const override {        \
    self().AdvanceStatesT(e, p, l, u0, u1, x0, x1, a_y0, dt, st);                                            \
  }
  NDSID_EFFECT_FORWARD(double)
  NDSID_EFFECT_FORWARD(Jet)
  NDSID_EFFECT_FORWARD(SmallJet)
#undef NDSID_EFFECT_FORWARD

  // Defaults: no term.
  template <class T>
  void InputsT(const T*, const InputSeries&, size_t, ModelInputs<T>&) const {}
  template <class T>
  void ForcesT(const T*, const Params<T>&, double, const AxleSlip<T>&, const State<T>&, const ModelInputs<T>&,
               const T*, ForceTerms<T>&) const {}
  template <class T>
  T MeasureT(const T*, const MeasurementContext<T>&, const T*) const { return T(0.0); }
  template <class T>
  T MeasureYawRateT(const T*, const MeasurementContext<T>&, const T*) const { return T(0.0); }
  template <class T>
  void InitStatesT(const T*, const Params<T>&, double, const ModelInputs<T>&, const State<T>&, T, T*) const {}
  template <class T>
  void AdvanceStatesT(const T*, const Params<T>&, double, const ModelInputs<T>&, const ModelInputs<T>&,
                      const State<T>&, const State<T>&, T, double, T*) const {}

 protected:
  explicit EffectImpl(EffectInfo info) : info_(std::move(info)) {
    // A template Derived does not define is found in this class: its member pointer is this
    // class's, not Derived's.
    terms_.inputs = Defines(&Derived::template InputsT<double>, &EffectImpl::template InputsT<double>);
    terms_.forces = Defines(&Derived::template ForcesT<double>, &EffectImpl::template ForcesT<double>);
    terms_.measure = Defines(&Derived::template MeasureT<double>, &EffectImpl::template MeasureT<double>);
    terms_.measure_yaw_rate = Defines(&Derived::template MeasureYawRateT<double>, &EffectImpl::template MeasureYawRateT<double>);
    terms_.init_states = Defines(&Derived::template InitStatesT<double>, &EffectImpl::template InitStatesT<double>);
    terms_.advance_states = Defines(&Derived::template AdvanceStatesT<double>, &EffectImpl::template AdvanceStatesT<double>);
  }

 private:
  template <class Own, class Default>
  static constexpr bool Defines(Own, Default) { return !std::is_same_v<Own, Default>; }
  const Derived& self() const { return static_cast<const Derived&>(*this); }
  EffectInfo info_;
};

#undef NDSID_EFFECT_TERMS

// All built-in effects (src/model/effects/; the table in builtin_effects.cc). Models are built
// from an EffectLibrary (effect_library.h): the built-ins plus a configuration's formulas.
std::vector<std::string> BuiltinEffectNames();

}  // namespace ndsid::model
