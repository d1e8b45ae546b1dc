#include "formula_check.h"

#include <cmath>
#include <sstream>

#include "ndsid/common/error.h"

namespace ndsid::model {

const std::vector<FormulaSample>& FormulaCheckSamples() {
  // A mid-size car and a heavy one; a moderate turn, a slow sharp turn, a fast lane change, and
  // straight driving (every state 0: a formula dividing by a_y or r fails there).
  static const std::vector<FormulaSample> samples = {
      {{1900, 2700, 75000, 120000, 1.15, 14.8}, 2.648, 17.0, 0.3, {0.003, 0.12}, 1.7, 0.3},
      {{1900, 2700, 75000, 120000, 1.15, 14.8}, 2.648, 4.0, -2.5, {-0.05, -0.5}, -2.0, -1.0},
      {{2600, 5200, 160000, 210000, 1.45, 16.5}, 3.1, 40.0, 0.04, {0.001, 0.02}, 0.8, -0.4},
      {{2600, 5200, 160000, 210000, 1.45, 16.5}, 3.1, 25.0, 0.0, {0.0, 0.0}, 0.0, 0.0},
  };
  return samples;
}

namespace {

std::string Number(double x) {
  std::ostringstream o;
  o << x;
  return o.str();
}

std::string Describe(const config::FormulaSpec& spec, const std::vector<double>& eta, const FormulaSample& s) {
  std::ostringstream o;
  for (size_t i = 0; i < eta.size(); ++i) o << (i ? ", " : "") << spec.params[i].name << " = " << eta[i];
  o << " at v = " << s.speed_mps << " m/s, d_sw = " << s.steer_rad << " rad, beta = " << s.state.beta
    << " rad, r = " << s.state.r << " rad/s, a_y = " << s.a_y << " m/s^2";
  return o.str();
}

}  // namespace

void CheckFormula(const config::FormulaSpec& spec, const std::string& where, const std::vector<FormulaEquationCheck>& eqs) {
  const size_t np = spec.params.size();
  std::vector<double> neutral(np), initial(np);
  for (size_t i = 0; i < np; ++i) {
    neutral[i] = spec.params[i].neutral;
    initial[i] = spec.params[i].initial;
  }
  // Points of the box: the neutral values, the initial values and every corner.
  std::vector<std::vector<double>> points = {neutral, initial};
  for (size_t corner = 0; corner < (size_t{1} << np); ++corner) {
    std::vector<double> eta(np);
    for (size_t i = 0; i < np; ++i) eta[i] = (corner >> i & 1) ? spec.params[i].upper : spec.params[i].lower;
    points.push_back(std::move(eta));
  }
  for (const FormulaEquationCheck& eq : eqs) {
    for (const FormulaSample& s : FormulaCheckSamples()) {
      for (size_t k = 0; k < points.size(); ++k) {
        const double t = eq.term(points[k], s);
        if (!std::isfinite(t)) {
          throw ConfigError(where + "." + eq.target + ": the formula is " + (std::isnan(t) ? "NaN" : "infinite") +
                            " with " + Describe(spec, points[k], s) +
                            " (it must be finite on the whole box: guard it, e.g. with clip() or select(), or narrow the box)");
        }
        if (k == 0 && !(std::abs(t) <= 1e-9)) {
          throw ConfigError(where + "." + eq.target + ": the formula does not reduce to the base model at the parameters' " +
                            "neutral values (a_y_meas must equal a_y and r_meas equal r; the other targets' terms must " +
                            "vanish): it adds " + Number(t) + " with " + Describe(spec, points[k], s));
        }
      }
    }
  }
}

}  // namespace ndsid::model
