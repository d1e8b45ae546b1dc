// Effects stated as formulas in the vehicle configuration (model.formulas): an effect without
// recompiling. The expression is parsed once and evaluated on double or Jet like the built-in
// effects' templates, so Ceres differentiates it and the diagnosis can score it.
//   a_y_meas: the measured a_y as a function of a_y, r, r_dot, v and the parameters
//   beta_dot / r_dot: a term added to beta' / r', over beta, r, v, d_sw, delta and the parameters

#include "builtin_effects.h"
#include "ndsid/common/expression.h"

namespace ndsid::model {
namespace {

enum class Target { kMeasurement, kBetaDot, kYawAccel };

class FormulaEffect final : public EffectImpl<FormulaEffect> {
 public:
  static constexpr int kMaxParams = 8;

  FormulaEffect(const config::FormulaSpec& spec, EffectInfo info)
      : EffectImpl(std::move(info)), target_(TargetOf(spec.target)), np_(static_cast<int>(spec.params.size())) {
    std::vector<std::string> vars = target_ == Target::kMeasurement ? std::vector<std::string>{"a_y", "r", "r_dot", "v"}
                                                                    : std::vector<std::string>{"beta", "r", "v", "d_sw", "delta"};
    nsig_ = static_cast<int>(vars.size());
    for (const auto& p : spec.params) vars.push_back(p.name);
    try {
      expr_ = Expression::Parse(spec.expression, vars);
    } catch (const ConfigError& e) {
      throw ConfigError(FormatLocation(spec.file, spec.line, 0, "model.formulas." + spec.name + ": " + e.what()));
    }
  }

  template <class T>
  T MeasureT(const T* eta, const MeasurementContext<T>& m, const T*) const {
    if (target_ != Target::kMeasurement) return T(0.0);
    T v[4 + kMaxParams] = {m.a_y, m.yaw_rate, m.yaw_accel, m.speed_mps};
    for (int i = 0; i < np_; ++i) v[nsig_ + i] = eta[i];
    return expr_.Evaluate(v) - m.a_y;
  }
  template <class T>
  void ForcesT(const T* eta, const Params<T>& p, double, const AxleSlip<T>&, const State<T>& x, const ModelInputs<T>& u,
               const T*, ForceTerms<T>& f) const {
    if (target_ == Target::kMeasurement) return;
    T v[5 + kMaxParams] = {x.beta, x.r, u.speed_mps, u.steer_rad, u.steer_rad / p.is};
    for (int i = 0; i < np_; ++i) v[nsig_ + i] = eta[i];
    const T term = expr_.Evaluate(v);
    if (target_ == Target::kBetaDot) f.gravity_lat_mps2 += term * u.speed_mps;  // beta' += term
    else f.yaw_accel_radps2 += term;
  }

 private:
  static Target TargetOf(const std::string& t) {
    if (t == "a_y_meas") return Target::kMeasurement;
    if (t == "beta_dot") return Target::kBetaDot;
    return Target::kYawAccel;
  }
  Target target_;
  int np_;
  int nsig_ = 0;
  Expression expr_;
};

}  // namespace

std::shared_ptr<const Effect> MakeFormulaEffect(const config::FormulaSpec& spec) {
  if (spec.params.size() > FormulaEffect::kMaxParams) {
    throw ConfigError("model.formulas." + spec.name + ": at most 8 parameters");
  }
  EffectInfo info;
  info.name = spec.name;
  info.description = spec.target + " = " + spec.expression + " (formula from the configuration)";
  info.signature = "user hypothesis";
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
  // The base model must nest at the neutral values: check the term vanishes at a test point.
  std::vector<double> eta;
  for (const auto& p : spec.params) eta.push_back(p.neutral);
  const Params<double> p{1900, 2700, 75000, 120000, 1.15, 14.8};
  ForceTerms<double> f{0, 0, 0, 0};
  effect->Forces(eta.data(), p, 2.648, {0.01, 0.005}, {0.003, 0.12}, {0.3, 17.0, 0.0}, nullptr, f);
  const double m = effect->Measure(eta.data(), {1.7, 0.12, 0.3, 17.0}, nullptr);
  if (std::abs(m) > 1e-12 || std::abs(f.gravity_lat_mps2) > 1e-12 || std::abs(f.yaw_accel_radps2) > 1e-12) {
    throw ConfigError("model.formulas." + spec.name +
                      ": the formula does not reduce to the base model at the parameters' neutral values "
                      "(a_y_meas must equal a_y, beta_dot/r_dot terms must vanish)");
  }
  return effect;
}

}  // namespace ndsid::model
