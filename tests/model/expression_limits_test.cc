// Limits of formula expressions (docs/reliability.md): ~13 000 nested parentheses
// crashed `ndsidd --check-config` by stack overflow, an 18 000-term sum passed it and crashed
// the daemon in evaluation. Both are located ConfigErrors now, at parse time.
#include <gtest/gtest.h>

#include <string>

#include "ndsid/config/config.h"
#include "ndsid/model/effect.h"
#include "ndsid/model/effect_library.h"
#include "ndsid/common/expression.h"

namespace ndsid::model {
namespace {

std::string ErrorOf(const std::string& text) {
  try {
    Expression::Parse(text, {"a_y", "k"});
  } catch (const ConfigError& e) {
    return e.what();
  }
  return "";
}

std::string Nested(int depth) { return std::string(depth, '(') + "a_y" + std::string(depth, ')'); }
std::string Sum(int terms) {
  std::string s = "a_y";
  for (int i = 1; i < terms; ++i) s += "+k";
  return s;
}

// Catches: the parser recursing once per parenthesis without a bound (the 13 000 case).
TEST(ExpressionLimits, DeepParenthesesAreALocatedErrorNotACrash) {
  const std::string e = ErrorOf(Nested(1300));  // within kMaxChars, far beyond kMaxDepth
  EXPECT_NE(e.find("nested deeper than 200 levels"), std::string::npos) << e;
  EXPECT_NE(e.find("column 201"), std::string::npos) << e;  // the parenthesis that is one too many
  EXPECT_LT(e.size(), 300u) << "the message quotes a long text cut short";
  EXPECT_EQ(ErrorOf(Nested(200)), "");
  EXPECT_DOUBLE_EQ(Expression::Parse(Nested(200), {"a_y"}).Evaluate(std::vector<double>{2.5}.data()), 2.5);
}

// Catches: a long chain of operators building a tree that Evaluate (and the destructor) walk
// recursively (the 18 000-term sum), and the same through right-associative powers and signs.
TEST(ExpressionLimits, LongOperatorChainsAreBounded) {
  EXPECT_NE(ErrorOf(Sum(1000)).find("nested deeper than 200 levels"), std::string::npos);
  const double v[2] = {1.0, 0.5};
  EXPECT_DOUBLE_EQ(Expression::Parse(Sum(200), {"a_y", "k"}).Evaluate(v), 1.0 + 199 * 0.5);
  std::string power = "a_y";
  for (int i = 0; i < 1000; ++i) power += "^k";
  EXPECT_NE(ErrorOf(power).find("nested deeper"), std::string::npos);
  EXPECT_NE(ErrorOf(std::string(1000, '-') + "a_y").find("nested deeper"), std::string::npos);
  EXPECT_NE(ErrorOf(std::string(1000, '+') + "a_y").find("nested deeper"), std::string::npos);
}

// Catches: an unbounded text (the 18 000-term sum is ~36 kB) reaching the parser at all.
TEST(ExpressionLimits, TextLongerThanTheLimitIsRejected) {
  const std::string e = ErrorOf(Sum(18'000));
  EXPECT_NE(e.find("36001 characters, more than the limit of 4096"), std::string::npos) << e.substr(0, 200);
}

// Catches: the limit error losing the configuration's file:line on its way through the formula
// effect (what --check-config and a SIGHUP reload print).
TEST(ExpressionLimits, FormulaErrorNamesTheConfigFileAndLine) {
  const config::Config c = config::ParseConfig(R"(vehicle: {name: car, wheelbase_m: 2.648, mass_kg: 1900}
source: {type: log, logs: [a.log]}
dbc: b.dbc
signals:
  steering_wheel_angle: {message: M, signal: S, unit: deg}
  vehicle_speed: {message: M, signal: V, unit: km/h}
  lateral_acceleration: {message: M, signal: A, unit: m/s^2}
model:
  formulas:
    deep: {a_y_meas: ")" + Nested(1300) + R"(", parameters: {k: {min: -1, max: 1}}}
)",
                                               "car.yaml");
  try {
    const EffectLibrary library(c.model_formulas);
    FAIL() << "accepted";
  } catch (const ConfigError& e) {
    const std::string m = e.what();
    EXPECT_EQ(m.rfind("car.yaml:10: model.formulas.deep.a_y_meas: expression", 0), 0u) << m.substr(0, 200);
  }
}

}  // namespace
}  // namespace ndsid::model
