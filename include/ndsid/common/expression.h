// Arithmetic expressions, parsed once at load time: the formula effects' hypotheses
// ("a_y + k3*a_y^3", evaluated on double or autodiff Jets, so a formula effect is differentiated
// like a built-in one) and the signal roles computed from several CAN signals
// ("STEER_ANGLE_SENSOR.STEER_ANGLE + STEER_ANGLE_SENSOR.STEER_FRACTION").
// Grammar: numbers, names (letters, digits, '_', and '.' inside: MESSAGE.SIGNAL), + - * /,
// ^ (right-associative), unary -, parentheses; comparisons == != < > <= >= (1 or 0, lowest
// precedence, not chained); sin cos tan tanh exp log sqrt abs sgn of one argument; min(a, b),
// max(a, b); clip(x, lo, hi) = min(max(x, lo), hi); select(condition, a, b) = a where
// condition != 0, else b.
#pragma once

#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "ndsid/common/error.h"

namespace ndsid {

struct ExprNode {
  enum class Kind { kNumber, kVariable, kAdd, kSub, kMul, kDiv, kPow, kNeg, kCall, kCompare, kSelect } kind;
  double number = 0;
  int variable = -1;     // index into the variable names given to ParseExpression
  std::string function;  // kCall: the function (min/max: a and b); kCompare: the operator ("==", "<", ...)
  std::unique_ptr<ExprNode> a, b, c;  // c: kSelect's else-branch
  int depth = 1;  // levels of this subtree (Evaluate recurses this deep)
};

class Expression {
 public:
  // Limits (docs/reliability.md): parsing and evaluation recurse, so the nesting is bounded;
  // parentheses, function calls, unary signs and every chained operator (a sum of n terms is n
  // levels deep) add one level.
  static constexpr size_t kMaxChars = 4096;
  static constexpr int kMaxDepth = 200;

  // Throws ConfigError "expression 'text', column C: message" on a syntax error, a name not in
  // `variables`, or a text longer than kMaxChars or nested deeper than kMaxDepth.
  static Expression Parse(const std::string& text, const std::vector<std::string>& variables);

  template <typename T>
  T Evaluate(const T* values) const {
    return Eval(*root_, values);
  }
  const std::string& text() const { return text_; }
  bool Uses(int variable) const;

 private:
  template <typename T>
  static T Eval(const ExprNode& n, const T* v) {
    using std::abs, std::cos, std::exp, std::log, std::pow, std::sin, std::sqrt, std::tan, std::tanh;
    switch (n.kind) {
      case ExprNode::Kind::kNumber: return T(n.number);
      case ExprNode::Kind::kVariable: return v[n.variable];
      case ExprNode::Kind::kAdd: return Eval(*n.a, v) + Eval(*n.b, v);
      case ExprNode::Kind::kSub: return Eval(*n.a, v) - Eval(*n.b, v);
      case ExprNode::Kind::kMul: return Eval(*n.a, v) * Eval(*n.b, v);
      case ExprNode::Kind::kDiv: return Eval(*n.a, v) / Eval(*n.b, v);
      case ExprNode::Kind::kNeg: return -Eval(*n.a, v);
      case ExprNode::Kind::kPow: {
        // Integer exponents as products (exact derivatives at 0, negative bases allowed).
        if (n.b->kind == ExprNode::Kind::kNumber && n.b->number == std::floor(n.b->number) &&
            std::abs(n.b->number) <= 8) {
          const int k = static_cast<int>(n.b->number);
          const T base = Eval(*n.a, v);
          T r = T(1.0);
          for (int i = 0; i < std::abs(k); ++i) r = r * base;
          return k >= 0 ? r : T(1.0) / r;
        }
        return pow(Eval(*n.a, v), Eval(*n.b, v));
      }
      case ExprNode::Kind::kCall: {
        const T x = Eval(*n.a, v);
        const std::string& f = n.function;
        if (n.b) {  // min, max: the chosen argument (and its derivative)
          const T y = Eval(*n.b, v);
          if (f == "min") return y < x ? y : x;
          return y > x ? y : x;
        }
        if (f == "sin") return sin(x);
        if (f == "cos") return cos(x);
        if (f == "tan") return tan(x);
        if (f == "tanh") return tanh(x);
        if (f == "exp") return exp(x);
        if (f == "log") return log(x);
        if (f == "sqrt") return sqrt(x);
        if (f == "sgn") return x > T(0.0) ? T(1.0) : (x < T(0.0) ? T(-1.0) : T(0.0));
        return abs(x);
      }
      case ExprNode::Kind::kCompare: {
        const T x = Eval(*n.a, v), y = Eval(*n.b, v);
        const std::string& op = n.function;
        const bool r = op == "==" ? x == y : op == "!=" ? x != y : op == "<" ? x < y : op == ">" ? x > y : op == "<=" ? x <= y : x >= y;
        return T(r ? 1.0 : 0.0);
      }
      case ExprNode::Kind::kSelect:
        return Eval(*n.a, v) != T(0.0) ? Eval(*n.b, v) : Eval(*n.c, v);
    }
    return T(0.0);
  }

  std::string text_;
  std::shared_ptr<const ExprNode> root_;
};

}  // namespace ndsid
