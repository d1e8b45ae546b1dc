// The expression grammar's parts used by role expressions (docs/configuration.md): dotted
// MESSAGE.SIGNAL names, comparisons, sgn and select.
#include "ndsid/common/expression.h"

#include <gtest/gtest.h>

#include <cmath>

#include "ndsid/common/error.h"

namespace ndsid {
namespace {

double Eval(const std::string& text, std::vector<double> v) {
  return Expression::Parse(text, {"M.A", "M.B", "N.C"}).Evaluate(v.data());
}

// Catches: a comparison binding tighter than a sum (a + b > c read as a + (b > c)), a select
// with its branches swapped, or sgn(0) taken as +1.
TEST(Expression, ComparisonsSgnAndSelect) {
  EXPECT_EQ(Eval("M.A + M.B > N.C", {1, 2, 2.5}), 1.0);
  EXPECT_EQ(Eval("M.A + M.B > N.C", {1, 1, 2.5}), 0.0);
  EXPECT_EQ(Eval("M.A == 3", {3, 0, 0}), 1.0);
  EXPECT_EQ(Eval("M.A != 3", {3, 0, 0}), 0.0);
  EXPECT_EQ(Eval("M.A <= M.B", {2, 2, 0}), 1.0);
  EXPECT_EQ(Eval("M.A < M.B", {2, 2, 0}), 0.0);
  EXPECT_EQ(Eval("M.A >= M.B", {1, 2, 0}), 0.0);
  EXPECT_EQ(Eval("sgn(M.A)", {-0.2, 0, 0}), -1.0);
  EXPECT_EQ(Eval("sgn(M.A)", {0, 0, 0}), 0.0);
  EXPECT_EQ(Eval("sgn(M.A)", {7, 0, 0}), 1.0);
  EXPECT_EQ(Eval("select(M.A == 1, -M.B, M.B)", {1, 4, 0}), -4.0);
  EXPECT_EQ(Eval("select(M.A == 1, -M.B, M.B)", {0, 4, 0}), 4.0);
  EXPECT_EQ(Eval("select(M.A, M.B, N.C) * 2", {0.5, 3, 5}), 6.0);
  EXPECT_EQ(Eval("M.A * 1.5 + M.B * 0.1", {-3, 4, 0}), -4.5 + 0.4);
  // Only the branch taken is evaluated, so a guarded division gives no NaN.
  EXPECT_EQ(Eval("select(M.B != 0, M.A / M.B, 0)", {1, 0, 0}), 0.0);
}

TEST(Expression, RoleGrammarErrorsAreLocated) {
  auto error = [](const std::string& text) -> std::string {
    try {
      Expression::Parse(text, {"M.A", "M.B"});
    } catch (const ConfigError& e) {
      return e.what();
    }
    return "no error";
  };
  EXPECT_NE(error("select(M.A, M.B)").find("select needs 3 arguments"), std::string::npos);
  EXPECT_NE(error("M.A < M.B < 3").find("column"), std::string::npos) << "comparisons do not chain";
  EXPECT_NE(error("M.A = 1").find("column"), std::string::npos);
  EXPECT_NE(error("M.X + 1").find("unknown name 'M.X'"), std::string::npos) << error("M.X + 1");
  EXPECT_EQ(error("M.A >= -M.B"), "no error");
}

}  // namespace
}  // namespace ndsid
