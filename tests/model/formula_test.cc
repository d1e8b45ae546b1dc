#include <gtest/gtest.h>

#include <cmath>

#include "ndsid/config/config.h"
#include "ndsid/common/expression.h"
#include "ndsid/model/model_spec.h"
#include "ndsid/model/simulate.h"

namespace ndsid::model {
namespace {

constexpr double kL = 2.648;
const std::vector<double> kBase = {1900, 2700, 75000, 120000, 1.15, 14.8};

double Eval(const std::string& text, std::vector<double> values = {}) {
  return Expression::Parse(text, {"x", "y"}).Evaluate(values.empty() ? std::vector<double>{0, 0}.data() : values.data());
}

// Catches: precedence or associativity errors that silently change a user's hypothesis.
TEST(Expression, PrecedenceAssociativityAndFunctions) {
  EXPECT_DOUBLE_EQ(Eval("1 + 2*3^2"), 19.0);
  EXPECT_DOUBLE_EQ(Eval("-2^2"), -4.0);
  EXPECT_DOUBLE_EQ(Eval("2^3^2"), 512.0);
  EXPECT_DOUBLE_EQ(Eval("(1 + 2)*3 - 4/2"), 7.0);
  EXPECT_DOUBLE_EQ(Eval("x*y^3 + tanh(0)", {2, -3}), -54.0);
  EXPECT_NEAR(Eval("sqrt(abs(x)) + exp(log(y))", {-4, 3}), 5.0, 1e-12);
}

TEST(Expression, ErrorsNameTheColumnAndTheKnownNames) {
  try {
    Expression::Parse("a_y + k4*a_y", {"a_y", "k3"});
    FAIL();
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_NE(m.find("column 7"), std::string::npos) << m;
    EXPECT_NE(m.find("unknown name 'k4'"), std::string::npos) << m;
    EXPECT_NE(m.find("a_y, k3"), std::string::npos) << m;
  }
  EXPECT_THROW(Expression::Parse("(a_y + 1", {"a_y"}), ConfigError);
  EXPECT_THROW(Expression::Parse("a_y +", {"a_y"}), ConfigError);
  EXPECT_THROW(Expression::Parse("frob(a_y)", {"a_y"}), ConfigError);
}

config::Config WithFormulas(const std::string& formulas) {
  return config::ParseConfig(R"(vehicle: {name: car, wheelbase_m: 2.648, mass_kg: 1900}
source: {type: log, logs: [a.log]}
dbc: b.dbc
signals:
  steering_wheel_angle: {message: M, signal: S, unit: deg}
  vehicle_speed: {message: M, signal: V, unit: km/h}
  lateral_acceleration: {message: M, signal: A, unit: m/s^2}
model:
  effects: []
  formulas:
)" + formulas, "car.yaml");
}

struct Stretch {
  std::vector<float> data;
  size_t n = 1000;
  Stretch() {
    data.resize(2 * n);
    for (size_t k = 0; k < n; ++k) {
      data[2 * k] = static_cast<float>(0.5 * std::sin(2 * M_PI * 0.4 * k * 0.02));
      data[2 * k + 1] = static_cast<float>(15.0 + 10.0 * k / n);
    }
  }
  InputSeries series() const { return {&data[0], &data[1], 2, n, 0.02}; }
};

std::vector<double> SimulateWith(const std::vector<std::string>& effects, double eta, const EffectLibrary& library) {
  const Stretch s;
  const ModelSpec spec = ModelSpec::FromNames(effects, library);
  std::vector<double> p = kBase;
  p.push_back(eta);
  std::vector<double> y(s.n);
  SimulateModel(spec, p.data(), kL, s.series(), y.data());
  return y;
}

// Catches: a formula effect that does not act like the built-in effect it restates — in the
// measurement (bias, lever arm) and in the dynamics (crossfall as beta' += g_y/v).
TEST(FormulaEffect, RestatedBuiltinsGiveTheSameModel) {
  const config::Config c = WithFormulas(R"(    my_bias: {a_y_meas: "a_y + b", parameters: {b: {min: -1, max: 1}}}
    my_lever: {a_y_meas: "a_y + xs*r_dot", parameters: {xs: {min: -2, max: 2, unit: m}}}
    my_bank: {beta_dot: "gy/v", parameters: {gy: {min: -1, max: 1}}}
)");
  const EffectLibrary library(c.model_formulas);
  const auto pairs = {std::pair{"my_bias", "accel_bias"}, std::pair{"my_lever", "lever_arm"}, std::pair{"my_bank", "crossfall"}};
  for (const auto& [formula, builtin] : pairs) {
    const auto a = SimulateWith({formula}, 0.3, library), b = SimulateWith({builtin}, 0.3, library),
               base = SimulateWith({formula}, 0.0, library);
    double diff = 0, effect = 0;
    for (size_t k = 0; k < a.size(); ++k) {
      diff = std::max(diff, std::abs(a[k] - b[k]));
      effect = std::max(effect, std::abs(a[k] - base[k]));
    }
    EXPECT_LT(diff, 1e-9) << formula;
    EXPECT_GT(effect, 0.05) << formula;  // and the term is not nothing
  }
}

// Catches: wrong derivatives of a formula (Ceres and the score test depend on them).
TEST(FormulaEffect, AutodiffMatchesNumericDerivative) {
  const config::Config c = WithFormulas(R"(    cubic: {a_y_meas: "a_y + k3*a_y^3", parameters: {k3: {min: -0.1, max: 0.1}}}
)");
  const EffectLibrary library(c.model_formulas);
  const Stretch s;
  const ModelSpec spec = ModelSpec::FromNames({"cubic"}, library);
  std::vector<Jet> pj;
  for (double v : kBase) pj.push_back(Jet(v, static_cast<int>(pj.size())));
  pj.push_back(Jet(0.01, 6));
  std::vector<Jet> y(s.n);
  SimulateModel(spec, pj.data(), kL, s.series(), y.data());
  const auto yp = SimulateWith({"cubic"}, 0.01 + 1e-6, library), ym = SimulateWith({"cubic"}, 0.01 - 1e-6, library);
  for (size_t k = 0; k < s.n; k += 13) EXPECT_NEAR(y[k].v[6], (yp[k] - ym[k]) / 2e-6, 1e-4 * (1 + std::abs(y[k].v[6])));
}

TEST(FormulaEffect, RejectsFormulasThatDoNotNestTheBaseModel) {
  const config::Config c = WithFormulas(R"(    shifted: {a_y_meas: "a_y + 0.1 + k", parameters: {k: {min: -1, max: 1}}}
)");
  EXPECT_THROW(EffectLibrary{c.model_formulas}, ConfigError);
  const config::Config d = WithFormulas(R"(    typo: {a_y_meas: "a_y + k*ay", parameters: {k: {min: -1, max: 1}}}
)");
  try {
    const EffectLibrary library(d.model_formulas);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("model.formulas.typo"), std::string::npos) << e.what();
  }
}

TEST(FormulaEffect, ConfigRejectsMissingTargetWithLine) {
  try {
    WithFormulas("    empty: {parameters: {k: {min: -1, max: 1}}}\n");
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("car.yaml:11"), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("needs one or more of a_y_meas, r_meas, beta_dot"), std::string::npos) << e.what();
  }
}

// The library is a value: formulas exist only in the library built from their configuration,
// so two configurations never see each other's effects (the old global registry leaked them).
TEST(EffectLibrary, FormulasBelongToTheirConfigurationOnly) {
  const config::Config c = WithFormulas(R"(    cubic: {a_y_meas: "a_y + k3*a_y^3", parameters: {k3: {min: -0.1, max: 0.1}}}
)");
  const EffectLibrary with(c.model_formulas);
  EXPECT_NE(with.Find("cubic"), nullptr);
  EXPECT_EQ(EffectLibrary::Builtin().Find("cubic"), nullptr);
  EXPECT_THROW(ModelSpec::FromNames({"cubic"}), ConfigError);
  const ModelSpec spec = ModelSpec::FromNames({"roll", "cubic"}, with);
  EXPECT_EQ(spec.effect_names(), (std::vector<std::string>{"roll", "cubic"}));  // built-ins first
  EXPECT_NE(spec.library().Find("cubic"), nullptr);  // discovery extends from the same set
  EXPECT_EQ(with.formula_names(), std::vector<std::string>{"cubic"});
  EXPECT_EQ(with.builtin_names(), BuiltinEffectNames());
}

// Catches: min/max/clip evaluating or differentiating the wrong branch.
TEST(Expression, MinMaxClipChooseTheirArgumentAndItsDerivative) {
  EXPECT_DOUBLE_EQ(Eval("min(x, y)", {2, -3}), -3.0);
  EXPECT_DOUBLE_EQ(Eval("max(x, y)", {2, -3}), 2.0);
  EXPECT_DOUBLE_EQ(Eval("clip(x, -1, 1)", {2, 0}), 1.0);
  EXPECT_DOUBLE_EQ(Eval("clip(x, -1, 1)", {-5, 0}), -1.0);
  EXPECT_DOUBLE_EQ(Eval("clip(x, -1, 1)", {0.25, 0}), 0.25);
  EXPECT_DOUBLE_EQ(Eval("max(x, 0) + select(x > y, 10, 20)", {3, 1}), 13.0);
  const Expression e = Expression::Parse("clip(3*x, -1, 1) + min(x, y)", {"x", "y"});
  const Jet in[2] = {Jet(0.2, 0), Jet(0.5, 1)};
  const Jet out = e.Evaluate(in);
  EXPECT_DOUBLE_EQ(out.a, 0.8);
  EXPECT_DOUBLE_EQ(out.v[0], 4.0);  // 3 (inside the clip) + 1 (x is the min)
  EXPECT_DOUBLE_EQ(out.v[1], 0.0);
  EXPECT_THROW(Expression::Parse("min(x)", {"x"}), ConfigError);
  EXPECT_THROW(Expression::Parse("clip(x, 1)", {"x"}), ConfigError);
}

std::vector<double> SimulateParams(const std::vector<std::string>& effects, const std::vector<double>& eta,
                                   const EffectLibrary& library, std::vector<double>* yaw = nullptr) {
  const Stretch s;
  const ModelSpec spec = ModelSpec::FromNames(effects, library);
  std::vector<double> p = kBase;
  p.insert(p.end(), eta.begin(), eta.end());
  std::vector<double> y(s.n), r(s.n);
  SimulateModel(spec, p.data(), kL, s.series(), y.data(), nullptr, r.data());
  if (yaw) *yaw = r;
  return y;
}

double MaxDiff(const std::vector<double>& a, const std::vector<double>& b, size_t from = 0) {
  double d = 0;
  for (size_t k = from; k < a.size(); ++k) d = std::max(d, std::abs(a[k] - b[k]));
  return d;
}

// Catches: axle targets, base parameters, the inputs in a measurement formula or the yaw-rate
// measurement target not acting as stated: each is checked against an equivalent built-in
// effect or formula, and against the base model (the term is not nothing).
TEST(FormulaEffect, AxleTargetsBaseParametersAndYawRateMeasurement) {
  const config::Config c = WithFormulas(R"F(    slip_front: {alpha_v: "-so/is", parameters: {so: {min: -0.1, max: 0.1, unit: rad}}}
    force_front: {F_v: "-cv*so/is", parameters: {so: {min: -0.1, max: 0.1, unit: rad}}}
    my_gyro: {r_meas: "r*(1 + s)", parameters: {s: {min: -0.2, max: 0.2}}}
    steer_read: {a_y_meas: "a_y + k*delta", parameters: {k: {min: -10, max: 10}}}
)F");
  const EffectLibrary library(c.model_formulas);
  const auto base = SimulateParams({"slip_front"}, {0.0}, library);
  const auto builtin = SimulateParams({"steer_offset"}, {0.02}, library);
  // The stretch starts in the base model's steady state, which the built-in's input offset moves
  // and a force term does not: the two agree once that start has decayed (8 s).
  EXPECT_LT(MaxDiff(SimulateParams({"slip_front"}, {0.02}, library), builtin, 400), 1e-6);
  EXPECT_LT(MaxDiff(SimulateParams({"force_front"}, {0.02}, library), SimulateParams({"slip_front"}, {0.02}, library)), 1e-9);
  EXPECT_GT(MaxDiff(builtin, base), 0.05);
  std::vector<double> r_formula, r_builtin, r_base;
  SimulateParams({"my_gyro"}, {0.05}, library, &r_formula);
  SimulateParams({"gyro_scale"}, {0.05}, library, &r_builtin);
  SimulateParams({"my_gyro"}, {0.0}, library, &r_base);
  EXPECT_LT(MaxDiff(r_formula, r_builtin), 1e-12);
  EXPECT_GT(MaxDiff(r_formula, r_base), 0.001);
  // a_y_meas reads the road-wheel angle: the measured a_y moves by k * d_sw / is, sample by sample.
  const Stretch s;
  const auto y = SimulateParams({"steer_read"}, {0.7}, library), y0 = SimulateParams({"steer_read"}, {0.0}, library);
  for (size_t k = 0; k < s.n; k += 37) EXPECT_NEAR(y[k] - y0[k], 0.7 * s.data[2 * k] / kBase[5], 1e-9) << k;
}

// Catches: the equations of one effect not sharing its parameter. Two targets reading only the
// states give the sum of two one-target effects with the parameter set equal, and the derivative
// by the shared parameter is the sum of the derivatives by the two.
TEST(FormulaEffect, SeveralTargetsShareTheirParameters) {
  const config::Config c = WithFormulas(R"F(    both: {alpha_v: "k*r", alpha_h: "k*r", parameters: {k: {min: -1, max: 1, unit: s}}}
    front: {alpha_v: "k1*r", parameters: {k1: {min: -1, max: 1, unit: s}}}
    rear: {alpha_h: "k2*r", parameters: {k2: {min: -1, max: 1, unit: s}}}
)F");
  const EffectLibrary library(c.model_formulas);
  const auto both = SimulateParams({"both"}, {0.05}, library);
  EXPECT_LT(MaxDiff(both, SimulateParams({"front", "rear"}, {0.05, 0.05}, library)), 1e-9);
  EXPECT_GT(MaxDiff(both, SimulateParams({"both"}, {0.0}, library)), 0.01);
  const Stretch s;
  auto jets = [&](const std::vector<std::string>& effects, const std::vector<double>& eta) {
    const ModelSpec spec = ModelSpec::FromNames(effects, library);
    std::vector<Jet> pj;
    for (double v : kBase) pj.push_back(Jet(v));
    for (size_t i = 0; i < eta.size(); ++i) pj.push_back(Jet(eta[i], static_cast<int>(6 + i)));
    std::vector<Jet> y(s.n);
    SimulateModel(spec, pj.data(), kL, s.series(), y.data());
    return y;
  };
  const auto jb = jets({"both"}, {0.05}), jfr = jets({"front", "rear"}, {0.05, 0.05});
  for (size_t k = 0; k < s.n; k += 29) EXPECT_NEAR(jb[k].v[6], jfr[k].v[6] + jfr[k].v[7], 1e-9 * (1 + std::abs(jb[k].v[6]))) << k;
}

std::string LoadError(const std::string& formulas) {
  try {
    const config::Config c = WithFormulas(formulas);
    const EffectLibrary library(c.model_formulas);
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

// Catches: a formula that is NaN or infinite somewhere in its box, a neutral value outside the
// box, or a parameter named like a base parameter loading silently (a NaN term then scores every
// candidate 0 and prints "RMSE -nan").
TEST(FormulaEffect, LoadCheckFindsNaNInTheBoxAndANeutralOutsideIt) {
  std::string m = LoadError("    ent: {a_y_meas: \"a_y + k*log(k)\", parameters: {k: {min: 0, max: 1}}}\n");
  EXPECT_NE(m.find("car.yaml:11"), std::string::npos) << m;
  EXPECT_NE(m.find("model.formulas.ent.a_y_meas: the formula is NaN with k = 0"), std::string::npos) << m;
  m = LoadError("    inv: {a_y_meas: \"a_y*(1 + 1/k)\", parameters: {k: {min: 0.5, max: 2}}}\n");
  EXPECT_NE(m.find("neutral 0 lies outside [0.5, 2]"), std::string::npos) << m;
  EXPECT_NE(m.find("car.yaml:11"), std::string::npos) << m;
  m = LoadError("    sat: {r_dot: \"k*r/abs(r)\", parameters: {k: {min: -1, max: 1}}}\n");  // 0/0 driving straight
  EXPECT_NE(m.find("sat.r_dot: the formula is NaN"), std::string::npos) << m;
  EXPECT_NE(m.find("r = 0 rad/s"), std::string::npos) << m;
  m = LoadError("    big: {F_h: \"k*exp(1000*k)\", parameters: {k: {min: -1, max: 1}}}\n");
  EXPECT_NE(m.find("big.F_h: the formula is infinite with k = 1"), std::string::npos) << m;
  m = LoadError("    shadow: {F_h: \"m*a_y\", parameters: {m: {min: -1, max: 1}}}\n");
  EXPECT_NE(m.find("parameter 'm' has the name of a state, input or base parameter"), std::string::npos) << m;
  m = LoadError("    half: {alpha_v: \"k\", alpha_h: \"0.01 + k\", parameters: {k: {min: -1, max: 1}}}\n");
  EXPECT_NE(m.find("half.alpha_h: the formula does not reduce to the base model"), std::string::npos) << m;
  // Guarded, the same hypotheses load.
  EXPECT_EQ(LoadError("    sat: {r_dot: \"k*clip(r/0.01, -1, 1)\", parameters: {k: {min: -1, max: 1}}}\n"), "");
  EXPECT_EQ(LoadError("    inv: {a_y_meas: \"a_y*k\", parameters: {k: {min: 0.5, max: 2, neutral: 1, initial: 1}}}\n"), "");
}

TEST(EffectLibrary, RejectsAFormulaNamedLikeABuiltinOrListedTwice) {
  const config::Config c = WithFormulas(R"(    roll: {a_y_meas: "a_y + k*a_y", parameters: {k: {min: -1, max: 1}}}
)");
  try {
    const EffectLibrary library(c.model_formulas);
    FAIL();
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("model.formulas.roll: the name of a built-in effect"), std::string::npos) << e.what();
  }
}

}  // namespace
}  // namespace ndsid::model
