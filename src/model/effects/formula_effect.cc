// Effects stated as formulas in the vehicle configuration (model.formulas): an effect without
// recompiling. Each of the effect's equations is parsed once and evaluated on double or Jet like
// the built-in effects' templates, so Ceres differentiates it and the diagnosis can score it.
// The targets (docs/adding-an-effect.md):
//   a_y_meas, r_meas: the measured a_y / yaw rate as a function (equal to a_y / r when neutral)
//   beta_dot, r_dot: a term added to beta' / r' (beta_dot is not felt by the accelerometer)
//   alpha_v, alpha_h: an angle added to the axle's slip angle (its force is c * angle more)
//   F_v, F_h: a force [N] added to the axle's lateral force
// Every equation reads the same names: the states, inputs and axle quantities (kVarNames), the
// base parameters and the effect's parameters, which all its equations share.

#include <algorithm>
#include <array>
#include <cmath>
#include <sstream>

#include "builtin_effects.h"
#include "formula_check.h"
#include "ndsid/common/expression.h"

namespace ndsid::model {
namespace {

enum class Target { kAyMeas, kRMeas, kBetaDot, kRDot, kAlphaV, kAlphaH, kForceV, kForceH };

// The names every equation may read, then the effect's parameters (index kNumVars + i).
enum Var { kBeta, kR, kV, kDsw, kDelta, kAy, kRDot, kAlphaV, kAlphaH, kFv, kFh, kM, kJz, kCv, kCh, kLv, kLh, kIs, kL, kNumVars };
constexpr const char* kVarNames[kNumVars] = {"beta", "r",   "v",  "d_sw", "delta", "a_y", "r_dot",
                                             "alpha_v", "alpha_h", "F_v", "F_h", "m", "Jz", "cv",
                                             "ch", "lv", "lh", "is", "l"};

Target TargetOf(const std::string& t) {
  static const std::pair<const char*, Target> kTargets[] = {
      {"a_y_meas", Target::kAyMeas}, {"r_meas", Target::kRMeas},   {"beta_dot", Target::kBetaDot},
      {"r_dot", Target::kRDot},      {"alpha_v", Target::kAlphaV}, {"alpha_h", Target::kAlphaH},
      {"F_v", Target::kForceV},      {"F_h", Target::kForceH}};
  for (const auto& [name, target] : kTargets) if (t == name) return target;
  throw ConfigError("unknown formula target '" + t + "'");
}

bool IsMeasurement(Target t) { return t == Target::kAyMeas || t == Target::kRMeas; }

class FormulaEffect final : public EffectImpl<FormulaEffect> {
 public:
  static constexpr int kMaxParams = 8;
  struct Equation {
    Target target;
    std::string name;  // the target's key, for messages
    Expression expr;
  };

  FormulaEffect(const config::FormulaSpec& spec, EffectInfo info) : EffectImpl(std::move(info)), np_(static_cast<int>(spec.params.size())) {
    std::vector<std::string> vars(std::begin(kVarNames), std::end(kVarNames));
    for (const auto& p : spec.params) {
      if (std::find(vars.begin(), vars.end(), p.name) != vars.end()) {
        throw ConfigError(Where(spec) + ": parameter '" + p.name + "' has the name of a state, input or base parameter");
      }
      vars.push_back(p.name);
    }
    for (const config::FormulaTarget& t : spec.targets) {
      try {
        eqs_.push_back({TargetOf(t.target), t.target, Expression::Parse(t.expression, vars)});
      } catch (const ConfigError& e) {
        throw ConfigError(Where(spec) + "." + t.target + ": " + e.what());
      }
      for (int v = 0; v < kNumVars; ++v) uses_[static_cast<size_t>(v)] = uses_[static_cast<size_t>(v)] || eqs_.back().expr.Uses(v);
    }
  }
  static std::string Where(const config::FormulaSpec& spec) {
    return FormatLocation(spec.file, spec.line, 0, "model.formulas." + spec.name);
  }
  const std::vector<Equation>& equations() const { return eqs_; }

  // The names at a measurement: the sample's states and inputs; the axle forces are those that
  // give the modelled a_y and r' (m a_y = F_v + F_h, Jz r' = lv F_v - lh F_h).
  template <class T>
  void MeasurementVars(const T* eta, const MeasurementContext<T>& m, T* v) const {
    const Params<T>& p = *m.params;
    const T lh = T(m.wheelbase_m) - p.lv;
    v[kBeta] = m.state ? m.state->beta : T(0.0);
    v[kR] = m.yaw_rate;
    v[kV] = m.speed_mps;
    v[kDsw] = m.inputs ? m.inputs->steer_rad : T(0.0);
    v[kAy] = m.a_y;
    v[kRDot] = m.yaw_accel;
    Common(eta, p, m.wheelbase_m, v);
    if (uses_[kAlphaV] || uses_[kAlphaH]) {
      const T r_by_v = v[kR] / v[kV];
      v[kAlphaV] = v[kDelta] - v[kBeta] - p.lv * r_by_v;
      v[kAlphaH] = lh * r_by_v - v[kBeta];
    }
    if (uses_[kFv] || uses_[kFh]) {
      v[kFv] = (p.m * m.a_y * lh + p.Jz * m.yaw_accel) / T(m.wheelbase_m);
      v[kFh] = (p.m * m.a_y * p.lv - p.Jz * m.yaw_accel) / T(m.wheelbase_m);
    }
  }
  // The names in the dynamics: the axle forces so far (the base model's and the effects' before
  // this one), and the a_y and r' they give.
  template <class T>
  void DynamicsVars(const T* eta, const Params<T>& p, double l, const AxleSlip<T>& slip, const State<T>& x,
                    const ModelInputs<T>& u, const ForceTerms<T>& f, T* v) const {
    v[kBeta] = x.beta;
    v[kR] = x.r;
    v[kV] = u.speed_mps;
    v[kDsw] = u.steer_rad;
    v[kAlphaV] = slip.front;
    v[kAlphaH] = slip.rear;
    v[kFv] = f.force_front_n;
    v[kFh] = f.force_rear_n;
    Common(eta, p, l, v);
    if (uses_[kAy]) v[kAy] = (f.force_front_n + f.force_rear_n) / p.m;
    if (uses_[kRDot]) v[kRDot] = (p.lv * f.force_front_n - v[kLh] * f.force_rear_n) / p.Jz + f.yaw_accel_radps2;
  }

  template <class T>
  T MeasureT(const T* eta, const MeasurementContext<T>& m, const T*) const {
    return MeasuredTerm(eta, m, Target::kAyMeas, m.a_y);
  }
  template <class T>
  T MeasureYawRateT(const T* eta, const MeasurementContext<T>& m, const T*) const {
    return MeasuredTerm(eta, m, Target::kRMeas, m.yaw_rate);
  }
  template <class T>
  void ForcesT(const T* eta, const Params<T>& p, double l, const AxleSlip<T>& slip, const State<T>& x,
               const ModelInputs<T>& u, const T*, ForceTerms<T>& f) const {
    if (!has_dynamics()) return;
    std::array<T, kNumVars + kMaxParams> v;
    DynamicsVars(eta, p, l, slip, x, u, f, v.data());
    ForceTerms<T> add{T(0.0), T(0.0), T(0.0), T(0.0)};
    for (const Equation& e : eqs_) {
      if (IsMeasurement(e.target)) continue;
      const T term = e.expr.Evaluate(v.data());
      switch (e.target) {
        case Target::kBetaDot: add.gravity_lat_mps2 += term * u.speed_mps; break;  // beta' += term
        case Target::kRDot: add.yaw_accel_radps2 += term; break;
        case Target::kAlphaV: add.force_front_n += p.cv * term; break;
        case Target::kAlphaH: add.force_rear_n += p.ch * term; break;
        case Target::kForceV: add.force_front_n += term; break;
        default: add.force_rear_n += term; break;
      }
    }
    f.force_front_n += add.force_front_n;
    f.force_rear_n += add.force_rear_n;
    f.gravity_lat_mps2 += add.gravity_lat_mps2;
    f.yaw_accel_radps2 += add.yaw_accel_radps2;
  }

  bool has_dynamics() const {
    return std::any_of(eqs_.begin(), eqs_.end(), [](const Equation& e) { return !IsMeasurement(e.target); });
  }

 private:
  template <class T>
  void Common(const T* eta, const Params<T>& p, double l, T* v) const {
    v[kM] = p.m;
    v[kJz] = p.Jz;
    v[kCv] = p.cv;
    v[kCh] = p.ch;
    v[kLv] = p.lv;
    v[kLh] = T(l) - p.lv;
    v[kIs] = p.is;
    v[kL] = T(l);
    v[kDelta] = v[kDsw] / p.is;
    for (int i = 0; i < np_; ++i) v[kNumVars + i] = eta[i];
  }
  template <class T>
  T MeasuredTerm(const T* eta, const MeasurementContext<T>& m, Target target, const T& base) const {
    T sum(0.0);
    bool any = false;
    std::array<T, kNumVars + kMaxParams> v;
    for (const Equation& e : eqs_) {
      if (e.target != target) continue;
      if (!any) MeasurementVars(eta, m, v.data());
      any = true;
      sum += e.expr.Evaluate(v.data()) - base;
    }
    return sum;
  }

  int np_;
  std::vector<Equation> eqs_;
  std::array<bool, kNumVars> uses_{};
};

// Evaluates one equation at a sample with the given parameters (for the load check).
double EvaluateAt(const FormulaEffect& effect, const FormulaEffect::Equation& eq, const std::vector<double>& eta,
                  const FormulaSample& s) {
  const Params<double> p = Params<double>::FromArray(s.base.data());
  std::array<double, kNumVars + FormulaEffect::kMaxParams> v{};
  if (IsMeasurement(eq.target)) {
    const ModelInputs<double> u{s.steer_rad, s.speed_mps, 0.0, s.state.r, true};
    const MeasurementContext<double> m{s.a_y, s.r_dot, s.state.r, s.speed_mps, &s.state, &u, &p, s.wheelbase_m};
    effect.MeasurementVars(eta.data(), m, v.data());
    return eq.expr.Evaluate(v.data()) - (eq.target == Target::kAyMeas ? s.a_y : s.state.r);
  }
  const ModelInputs<double> u{s.steer_rad, s.speed_mps, 0.0, s.state.r, true};
  const double delta = s.steer_rad / p.is, lh = s.wheelbase_m - p.lv;
  const AxleSlip<double> slip{delta - s.state.beta - p.lv * s.state.r / s.speed_mps, lh * s.state.r / s.speed_mps - s.state.beta};
  const ForceTerms<double> f{p.cv * slip.front, p.ch * slip.rear, 0.0, 0.0};
  effect.DynamicsVars(eta.data(), p, s.wheelbase_m, slip, s.state, u, f, v.data());
  return eq.expr.Evaluate(v.data());
}

}  // namespace

std::shared_ptr<const Effect> MakeFormulaEffect(const config::FormulaSpec& spec) {
  if (spec.params.size() > FormulaEffect::kMaxParams) {
    throw ConfigError(FormulaEffect::Where(spec) + ": at most 8 parameters");
  }
  EffectInfo info;
  info.name = spec.name;
  std::string equations;
  for (const auto& t : spec.targets) equations += (equations.empty() ? "" : "; ") + t.target + " = " + t.expression;
  info.description = equations + " (formula from the configuration)";
  info.signature = "user hypothesis";
  // An effect that acts through the yaw-rate measurement alone is a yaw-rate sensor effect.
  info.yaw_rate_sensor = std::all_of(spec.targets.begin(), spec.targets.end(),
                                     [](const config::FormulaTarget& t) { return t.target == "r_meas"; });
  info.needs_yaw_rate_output = info.yaw_rate_sensor;
  for (const auto& p : spec.params) {
    info.params.push_back({.name = p.name,
                           .unit = p.unit,
                           .lower = p.lower,
                           .upper = p.upper,
                           .initial = p.initial,
                           .neutral = p.neutral,
                           .typical = 0.5 * (p.upper - p.lower)});
  }
  auto effect = std::make_shared<FormulaEffect>(spec, std::move(info));
  std::vector<FormulaEquationCheck> checks;
  for (const auto& eq : effect->equations()) {
    checks.push_back({eq.name, [&effect, &eq](const std::vector<double>& eta, const FormulaSample& s) {
                        return EvaluateAt(*effect, eq, eta, s);
                      }});
  }
  CheckFormula(spec, FormulaEffect::Where(spec), checks);
  return effect;
}

}  // namespace ndsid::model
