#include "ndsid/common/expression.h"

#include <algorithm>
#include <cctype>
#include <cstdlib>
#include <functional>
#include <string>

namespace ndsid {
namespace {

class Parser {
 public:
  Parser(const std::string& text, const std::vector<std::string>& vars) : s_(text), vars_(vars) {}

  std::unique_ptr<ExprNode> Parse() {
    if (s_.size() > Expression::kMaxChars) {
      Fail(std::to_string(s_.size()) + " characters, more than the limit of " + std::to_string(Expression::kMaxChars));
    }
    auto n = Compare();
    Skip();
    if (pos_ < s_.size()) Fail("unexpected '" + std::string(1, s_[pos_]) + "'");
    return n;
  }

 private:
  [[noreturn]] void Fail(const std::string& msg) const {
    constexpr size_t kQuoted = 60;  // a long text is cut in the message; the column locates
    const std::string quoted = s_.size() <= kQuoted ? s_ : s_.substr(0, kQuoted) + "...";
    throw ConfigError("expression '" + quoted + "', column " + std::to_string(pos_ + 1) + ": " + msg);
  }
  // Bounds the parser's recursion (parentheses, calls, unary signs) at kMaxDepth.
  class Nest {
   public:
    explicit Nest(Parser& p) : p_(p) {
      if (++p_.nesting_ > Expression::kMaxDepth) {
        --p_.pos_;  // point at the parenthesis, sign or '^' just read
        p_.FailDepth();
      }
    }
    ~Nest() { --p_.nesting_; }

   private:
    Parser& p_;
  };
  [[noreturn]] void FailDepth() const {
    Fail("nested deeper than " + std::to_string(Expression::kMaxDepth) +
         " levels (parentheses, calls, signs and each chained operator count)");
  }
  void Skip() {
    while (pos_ < s_.size() && std::isspace(static_cast<unsigned char>(s_[pos_]))) ++pos_;
  }
  bool Eat(char c) {
    Skip();
    if (pos_ < s_.size() && s_[pos_] == c) {
      ++pos_;
      return true;
    }
    return false;
  }
  std::unique_ptr<ExprNode> Make(ExprNode::Kind k, std::unique_ptr<ExprNode> a, std::unique_ptr<ExprNode> b) const {
    auto n = std::make_unique<ExprNode>();
    n->kind = k;
    n->depth = 1 + std::max(a ? a->depth : 0, b ? b->depth : 0);
    n->a = std::move(a);
    n->b = std::move(b);
    if (n->depth > Expression::kMaxDepth) FailDepth();  // evaluation would recurse this deep
    return n;
  }
  // Lowest precedence, not chained: "a < b" (1 or 0).
  std::unique_ptr<ExprNode> Compare() {
    auto n = Sum();
    Skip();
    for (const char* op : {"==", "!=", "<=", ">=", "<", ">"}) {
      const size_t len = std::char_traits<char>::length(op);
      if (s_.compare(pos_, len, op) == 0) {
        pos_ += len;
        auto r = Make(ExprNode::Kind::kCompare, std::move(n), Sum());
        r->function = op;
        return r;
      }
    }
    return n;
  }
  std::unique_ptr<ExprNode> Sum() {
    auto n = Product();
    for (;;) {
      if (Eat('+')) n = Make(ExprNode::Kind::kAdd, std::move(n), Product());
      else if (Eat('-')) n = Make(ExprNode::Kind::kSub, std::move(n), Product());
      else return n;
    }
  }
  std::unique_ptr<ExprNode> Product() {
    auto n = Unary();
    for (;;) {
      if (Eat('*')) n = Make(ExprNode::Kind::kMul, std::move(n), Unary());
      else if (Eat('/')) n = Make(ExprNode::Kind::kDiv, std::move(n), Unary());
      else return n;
    }
  }
  std::unique_ptr<ExprNode> Unary() {
    if (Eat('-')) {
      const Nest nest(*this);
      return Make(ExprNode::Kind::kNeg, Unary(), nullptr);
    }
    if (Eat('+')) {
      const Nest nest(*this);
      return Unary();
    }
    return Power();
  }
  std::unique_ptr<ExprNode> Power() {
    auto base = Atom();
    if (Eat('^')) {  // right-associative: recurses
      const Nest nest(*this);
      return Make(ExprNode::Kind::kPow, std::move(base), Unary());
    }
    return base;
  }
  std::unique_ptr<ExprNode> Atom() {
    Skip();
    if (pos_ >= s_.size()) Fail("unexpected end of expression");
    const char c = s_[pos_];
    if (Eat('(')) {
      const Nest nest(*this);
      auto n = Compare();
      if (!Eat(')')) Fail("expected ')'");
      return n;
    }
    if (std::isdigit(static_cast<unsigned char>(c)) || c == '.') {
      const char* start = s_.c_str() + pos_;
      char* end = nullptr;
      const double v = std::strtod(start, &end);
      if (end == start) Fail("bad number");
      pos_ += static_cast<size_t>(end - start);
      auto n = std::make_unique<ExprNode>();
      n->kind = ExprNode::Kind::kNumber;
      n->number = v;
      return n;
    }
    if (std::isalpha(static_cast<unsigned char>(c)) || c == '_') {
      const size_t start = pos_;
      // A name; a '.' inside joins MESSAGE.SIGNAL (followed by a letter or '_').
      while (pos_ < s_.size() &&
             (std::isalnum(static_cast<unsigned char>(s_[pos_])) || s_[pos_] == '_' ||
              (s_[pos_] == '.' && pos_ + 1 < s_.size() &&
               (std::isalpha(static_cast<unsigned char>(s_[pos_ + 1])) || s_[pos_ + 1] == '_'))))
        ++pos_;
      const std::string name = s_.substr(start, pos_ - start);
      if (Eat('(')) {
        if (name == "select") {  // select(condition, a, b)
          const Nest nest(*this);
          auto cond = Compare();
          if (!Eat(',')) Fail("select needs 3 arguments: select(condition, a, b)");
          auto then = Compare();
          if (!Eat(',')) Fail("select needs 3 arguments: select(condition, a, b)");
          auto otherwise = Compare();
          if (!Eat(')')) Fail("expected ')' after the 3 arguments of select");
          const int depth = 1 + std::max({cond->depth, then->depth, otherwise->depth});
          auto n = Make(ExprNode::Kind::kSelect, std::move(cond), std::move(then));
          n->depth = std::max(n->depth, depth);
          if (n->depth > Expression::kMaxDepth) FailDepth();
          n->c = std::move(otherwise);
          return n;
        }
        if (name == "min" || name == "max") return TwoArguments(name);
        if (name == "clip") return Clip();
        static const char* kFunctions[] = {"sin", "cos", "tan", "tanh", "exp", "log", "sqrt", "abs", "sgn"};
        bool known = false;
        for (const char* f : kFunctions) known = known || name == f;
        if (!known) {
          pos_ = start;
          Fail("unknown function '" + name + "' (known: sin cos tan tanh exp log sqrt abs sgn min max clip select)");
        }
        const Nest nest(*this);
        auto n = Make(ExprNode::Kind::kCall, Compare(), nullptr);
        n->function = name;
        if (!Eat(')')) Fail("expected ')' after the argument of " + name);
        return n;
      }
      for (size_t i = 0; i < vars_.size(); ++i) {
        if (vars_[i] == name) {
          auto n = std::make_unique<ExprNode>();
          n->kind = ExprNode::Kind::kVariable;
          n->variable = static_cast<int>(i);
          return n;
        }
      }
      pos_ = start;
      std::string known;
      for (const auto& v : vars_) known += (known.empty() ? "" : ", ") + v;
      Fail("unknown name '" + name + "' (signals and parameters here: " + known + ")");
    }
    Fail("unexpected '" + std::string(1, c) + "'");
  }

  // min(a, b), max(a, b): a call with two arguments.
  std::unique_ptr<ExprNode> TwoArguments(const std::string& name) {
    const Nest nest(*this);
    auto a = Compare();
    if (!Eat(',')) Fail(name + " needs 2 arguments: " + name + "(a, b)");
    auto b = Compare();
    if (!Eat(')')) Fail("expected ')' after the 2 arguments of " + name);
    auto n = Make(ExprNode::Kind::kCall, std::move(a), std::move(b));
    n->function = name;
    return n;
  }
  // clip(x, lo, hi) = min(max(x, lo), hi).
  std::unique_ptr<ExprNode> Clip() {
    const Nest nest(*this);
    auto x = Compare();
    if (!Eat(',')) Fail("clip needs 3 arguments: clip(x, lo, hi)");
    auto lo = Compare();
    if (!Eat(',')) Fail("clip needs 3 arguments: clip(x, lo, hi)");
    auto hi = Compare();
    if (!Eat(')')) Fail("expected ')' after the 3 arguments of clip");
    auto lower = Make(ExprNode::Kind::kCall, std::move(x), std::move(lo));
    lower->function = "max";
    auto n = Make(ExprNode::Kind::kCall, std::move(lower), std::move(hi));
    n->function = "min";
    return n;
  }

  const std::string& s_;
  const std::vector<std::string>& vars_;
  size_t pos_ = 0;
  int nesting_ = 0;
};

bool UsesVariable(const ExprNode& n, int v) {
  if (n.kind == ExprNode::Kind::kVariable) return n.variable == v;
  return (n.a && UsesVariable(*n.a, v)) || (n.b && UsesVariable(*n.b, v)) || (n.c && UsesVariable(*n.c, v));
}

}  // namespace

Expression Expression::Parse(const std::string& text, const std::vector<std::string>& variables) {
  Expression e;
  e.text_ = text;
  e.root_ = Parser(text, variables).Parse();
  return e;
}

bool Expression::Uses(int variable) const { return UsesVariable(*root_, variable); }

}  // namespace ndsid
