// The load check of a formula effect (model.formulas): its equations must give the base model
// at the parameters' neutral values and be finite everywhere in the parameter box, on sample
// states from straight driving to a slow sharp turn. A formula that fails either is a located
// configuration error at load, not a NaN in the middle of a fit.
#pragma once

#include <array>
#include <functional>
#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/model/single_track.h"

namespace ndsid::model {

// One sample state and the vehicle it belongs to.
struct FormulaSample {
  std::array<double, kNumParams> base;  // m, Jz, cv, ch, lv, is
  double wheelbase_m;
  double speed_mps, steer_rad;  // v, d_sw
  State<double> state;          // beta, r
  double a_y, r_dot;            // the modelled CG a_y and r'
};

// One equation: its target's name and its term at (parameters, sample) — the measured value
// minus the base model's for a_y_meas / r_meas, the added term for the others.
struct FormulaEquationCheck {
  std::string target;
  std::function<double(const std::vector<double>& eta, const FormulaSample& s)> term;
};

// The sample states the check uses (documented in docs/adding-an-effect.md).
const std::vector<FormulaSample>& FormulaCheckSamples();

// Throws ConfigError "<where>.<target>: ..." when an equation does not vanish at the neutral
// values, or is NaN or infinite at the neutral values, the initial values or any corner of
// the box, on any sample.
void CheckFormula(const config::FormulaSpec& spec, const std::string& where, const std::vector<FormulaEquationCheck>& eqs);

}  // namespace ndsid::model
