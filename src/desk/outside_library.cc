#include "outside_library.h"

#include <cmath>
#include <optional>

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

// The final model's a_y residual (the last rung's diagnosis, when it is of that model) led by a
// shape in the steering rather than by a gain: an offset odd in the steering (on-centre play, or
// road wheels that lead the steering wheel near the centre) or even in it (the road wheels turn
// more to one side). The output is already unexplained (its noise floor says so); this chooses
// the description, so the shape must lead the signatures by ΔRSS, explain at least twice what
// the best signature of another kind does (a gain at every speed, one changing with speed, a
// bias, a lag, ...), and be more than noise (|robust z| >= 2; the robust z is clustered by chunk
// and conservative). The steering reaches both outputs, so one verdict names it for both.
std::optional<OutsideLibrary> SteeringShape(const discover::Ladder& ladder) {
  if (ladder.diagnoses.empty() || ladder.rungs.empty() || ladder.diagnoses.back().model != ladder.rungs.back().model)
    return std::nullopt;
  const std::vector<discover::SignatureCorrelation>& sig = ladder.diagnoses.back().signatures;
  auto steering = [](const discover::SignatureCorrelation& s) { return s.key == "steer_odd" || s.key == "steer_even"; };
  if (sig.empty() || !steering(sig.front()) || std::abs(sig.front().z_robust) < 2.0) return std::nullopt;
  const discover::SignatureCorrelation& top = sig.front();  // by drss
  for (const auto& s : sig) {
    if (!steering(s) && 2.0 * s.drss > top.drss) return std::nullopt;
  }
  OutsideLibrary o;
  const std::string numbers = Fmt("r = %+.2f, robust z = %+.1f", top.correlation, top.z_robust);
  if (top.key == "steer_odd") {
    o.signature = "offset odd in the steering";
    const bool play = top.correlation < 0;  // the car answers the steering less than modelled near the centre
    o.text = "not one of my effects: the error behaves like an offset odd in the steering, w(v) sgn(d_sw) (" + numbers +
             "): " +
             (play ? "the road wheels follow the steering wheel with on-centre play (a dead band). A formula that "
                     "states it, the play b at the steering wheel [rad]:"
                   : "the road wheels lead the steering wheel near the centre (a preload). A formula that states it, "
                     "the lead c at the steering wheel [rad]:");
    o.formula_template = play ? "model:\n  formulas:\n    steering_play:\n      alpha_v: \"-clip(d_sw, -b, b)/is\"\n"
                                "      parameters:\n        b: {min: 0, max: 0.1, unit: rad}\n"
                              : "model:\n  formulas:\n    steering_lead:\n      alpha_v: \"clip(d_sw, -c, c)/is\"\n"
                                "      parameters:\n        c: {min: 0, max: 0.1, unit: rad}\n";
  } else {
    o.signature = "offset even in the steering";
    o.text = "not one of my effects: the error behaves like an offset even in the steering, w(v) |d_sw| (" + numbers +
             "): the road wheels turn more to one side than to the other (a steering unequal left and right). A "
             "formula that states it, k > 0 for more to the left:";
    o.formula_template = "model:\n  formulas:\n    steering_unequal:\n      alpha_v: \"k*abs(d_sw)/is\"\n"
                         "      parameters:\n        k: {min: -0.3, max: 0.3}\n";
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
  const std::optional<OutsideLibrary> steering = SteeringShape(ladder);
  if (steering) {  // the first unexplained output gets the verdict and its template, the other a pointer to it
    for (const auto& v : ladder.verdicts) {
      if (!v.unexplained) continue;
      OutsideLibrary o = *steering;
      o.output = v.output;
      if (!out.empty()) {
        o.text = "the same steering property reaches the " + v.output + " (the formula above states it for both outputs)";
        o.formula_template.clear();
      }
      out.push_back(o);
    }
    return out;
  }
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
