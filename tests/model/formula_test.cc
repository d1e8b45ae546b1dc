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
    EXPECT_NE(std::string(e.what()).find("needs one of a_y_meas"), std::string::npos) << e.what();
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
