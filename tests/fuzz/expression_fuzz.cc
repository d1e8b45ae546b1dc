// Fuzz target: a formula expression through Expression::Parse over a fixed set of names, and
// one evaluation of what parses (dotted names as in role expressions). Only ConfigError may come out; no input may exhaust the stack.
#include <cstdint>
#include <string>
#include <vector>

#include "ndsid/common/expression.h"

extern "C" int LLVMFuzzerTestOneInput(const uint8_t* data, size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  static const std::vector<std::string> kNames = {"a_y", "r", "r_dot", "v", "M.A", "M.B"};
  try {
    const auto e = ndsid::Expression::Parse(text, kNames);
    const double values[6] = {1.5, 0.1, -0.2, 20.0, 0.01, -3.0};
    volatile double r = e.Evaluate(values);
    (void)r;
    (void)e.Uses(0);
  } catch (const ndsid::ConfigError&) {
  }
  return 0;
}
