#include "outside_library.h"

#include "ndsid/common/format.h"

namespace ndsid::desk {
namespace {

std::string Bands(const std::vector<GainBand>& bands) {
  std::string s;
  for (const GainBand& b : bands) {
    if (!b.judged) continue;
    s += Fmt("%s%s m/s %+.1f %%%s", s.empty() ? "" : ", ", b.label.c_str(), 100 * b.gain, b.flagged ? "*" : "");
  }
  return s;
}

// The signature of one output's signed view (model 0), and the formula that states it.
OutsideLibrary Judge(const GainView& view, const std::string& output, bool yaw) {
  OutsideLibrary o;
  o.output = output;
  const std::vector<GainBand>& bands = view.per_model.at(0);
  int flagged = 0, positive = 0;
  for (const GainBand& b : bands) {
    if (!b.flagged) continue;
    ++flagged;
    if (b.gain > 0) ++positive;
  }
  const std::string gains = Bands(bands);
  if (view.speed_dependent.at(0)) {
    o.signature = "gain changes with speed";
    o.text = "not one of my effects: the " + output + " error behaves like a gain that changes with speed (" + gains +
             "; * flagged): a tyre, compliance or aero property that depends on speed. A formula that states one, "
             "the rear axle's stiffness growing or falling with v^2 (try alpha_v for the front axle):";
    o.formula_template =
        "model:\n  formulas:\n    stiffness_with_speed:\n      alpha_h: \"k*(v/30)^2*alpha_h\"\n"
        "      parameters:\n        k: {min: -0.6, max: 0.6}\n";
  } else if (flagged >= 2 && (positive == 0 || positive == flagged)) {
    o.signature = "gain at every speed";
    o.text = "the " + output + " error behaves like one gain at every speed (" + gains + "; * flagged): a scale of " +
             (yaw ? "the yaw-rate sensor" : "the accelerometer or of the tyres' balance") + ". A formula that states it:";
    o.formula_template = yaw ? "model:\n  formulas:\n    yaw_gain:\n      r_meas: \"r*(1 + s)\"\n      parameters:\n        s: {min: -0.2, max: 0.2}\n"
                             : "model:\n  formulas:\n    a_y_gain:\n      a_y_meas: \"a_y*(1 + s)\"\n      parameters:\n        s: {min: -0.2, max: 0.2}\n";
  } else {
    o.signature = "not a gain";
    o.text = "not one of my effects, and not a gain: the " + output + " error's gain per speed band agrees (" + gains +
             "), so what is left is an offset, a lag or a nonlinearity the library lacks (compare's bins by a_y, "
             "steering rate and speed show where)";
  }
  return o;
}

}  // namespace

std::vector<OutsideLibrary> JudgeOutsideLibrary(const ReplayedData& data, const discover::Ladder& ladder,
                                                const std::vector<std::string>& final_effects) {
  std::vector<OutsideLibrary> out;
  bool any = false;
  for (const auto& v : ladder.verdicts) any = any || v.unexplained;
  if (!any || ladder.rungs.empty() || !ladder.rungs.back().fit.valid) return out;
  const Comparison c = Compare(data, {FittedModel{"model", final_effects, ladder.rungs.back().fit}}, std::nullopt);
  for (const auto& v : ladder.verdicts) {
    if (!v.unexplained) continue;
    const bool yaw = v.output != "a_y";
    if (yaw && !c.has_yaw_rate) continue;
    out.push_back(Judge(yaw ? c.yaw_gains : c.gains, v.output, yaw));
  }
  return out;
}

}  // namespace ndsid::desk
