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
             "; * flagged): a tyre, compliance or aero property that depends on speed, or a chassis system that "
             "steers the rear axle by a gain that changes with speed. The formulas that state either, the rear axle's "
             "stiffness growing or falling with v^2 (try alpha_v for the front axle) and the rear wheels steered "
             "with the front, against it at low speed and with it at high speed; list both as hypotheses "
             "(--candidates +stiffness_with_speed,+rear_steer_with_speed) and the ladder keeps the one the held-out "
             "drives confirm:";
    o.formula_template =
        "model:\n  formulas:\n    stiffness_with_speed:\n      alpha_h: \"k*(v/30)^2*alpha_h\"\n"
        "      parameters:\n        k: {min: -0.6, max: 0.6}\n"
        "    rear_steer_with_speed:\n      alpha_h: \"(c0 + c2*(v/30)^2)*d_sw/is\"\n"
        "      parameters:\n        c0: {min: -0.3, max: 0.3}\n        c2: {min: -0.5, max: 0.5}\n";
  } else if (flagged >= 2 && (positive == 0 || positive == flagged)) {
    o.signature = "gain at every speed";
    o.text = "the " + output + " error behaves like one gain at every speed (" + gains + "; * flagged): a scale of " +
             (yaw ? "the yaw-rate sensor" : "the accelerometer or of the tyres' balance") + ". A formula that states it:";
    o.formula_template = yaw ? "model:\n  formulas:\n    yaw_gain:\n      r_meas: \"r*(1 + s)\"\n      parameters:\n        s: {min: -0.2, max: 0.2}\n"
                             : "model:\n  formulas:\n    a_y_gain:\n      a_y_meas: \"a_y*(1 + s)\"\n      parameters:\n        s: {min: -0.2, max: 0.2}\n";
  } else {
    o.signature = "not a gain";
    o.text = gains.empty()
                 ? "not one of my effects: no speed band has turning enough to judge the " + output +
                       " error's gain, so what is left is an offset, a lag, a nonlinearity or a gain the library lacks "
                       "(compare's bins by a_y, steering rate and speed show where)"
                 : "not one of my effects, and not a gain: the " + output + " error's gain per speed band agrees (" + gains +
                       "), so what is left is an offset, a lag or a nonlinearity the library lacks (compare's bins by a_y, "
                       "steering rate and speed show where)";
  }
  return o;
}

// The final model's a_y residual (the last rung's diagnosis, when it is of that model) led by a
// shape rather than by a gain: an offset odd in the steering (on-centre play, or road wheels that
// lead the steering wheel near the centre), or an error even in the turn — the road wheels turn
// more to one side (w(v) |d_sw|), or the accelerometer reads both turns shifted the same way
// (a_y^2). The output is already unexplained (its noise floor says so); this chooses the
// description, so the shape must lead the signatures by ΔRSS, explain at least twice what the best
// signature of another kind does (a gain at every speed, one changing with speed, a bias, a lag,
// ...), and be more than noise (|robust z| >= 2; the robust z is clustered by chunk and
// conservative). The two even shapes are alike in a_y (|d_sw| and a_y^2 rise together); with a
// yaw rate the measured a_y - v r tells them apart (KinematicShare): a steering property moves
// a_y and v r alike, an accelerometer's error stays in their difference. Without a yaw rate the
// leading one is named and the other given as the alternative.
struct Shape {
  OutsideLibrary verdict;
  bool both_outputs = true;  // a property of the car: it reaches the yaw rate too
};

bool IsShape(const discover::SignatureCorrelation& s) { return s.key == "steer_odd" || s.key == "steer_even" || s.key == "a_y2"; }

// The share of the a_y residual's even shape `top` that the measured a_y - v r (no model in it)
// carries, each the slope on the shape beside a constant and a_y: about 1 when the accelerometer
// bends its reading (the gyro does not see it), about 0 when the car's steering does (a_y and v r
// move together); and its standard error. Nullopt without a yaw rate.
struct Share {
  double value, se;
};
std::optional<Share> KinematicShare(const discover::SignatureCorrelation& top,
                                    const std::vector<discover::SignatureCorrelation>& kin) {
  if (top.slope == 0) return std::nullopt;
  for (const auto& s : kin) {
    if (s.key == top.key) return Share{s.slope / top.slope, s.slope_se / std::abs(top.slope)};
  }
  return std::nullopt;
}

Shape SteeringOdd(const std::string& numbers, bool play) {
  Shape sh;
  OutsideLibrary& o = sh.verdict;
  o.signature = "offset odd in the steering";
  o.text = "not one of my effects: the error behaves like an offset odd in the steering, w(v) sgn(d_sw) (" + numbers + "): " +
           (play ? "the road wheels follow the steering wheel with on-centre play (a dead band). A formula that "
                   "states it, the play b at the steering wheel [rad]:"
                 : "the road wheels lead the steering wheel near the centre (a preload). A formula that states it, "
                   "the lead c at the steering wheel [rad]:");
  o.formula_template = play ? "model:\n  formulas:\n    steering_play:\n      alpha_v: \"-clip(d_sw, -b, b)/is\"\n"
                              "      parameters:\n        b: {min: 0, max: 0.1, unit: rad}\n"
                            : "model:\n  formulas:\n    steering_lead:\n      alpha_v: \"clip(d_sw, -c, c)/is\"\n"
                              "      parameters:\n        c: {min: 0, max: 0.1, unit: rad}\n";
  return sh;
}

Shape SteeringEven(const std::string& numbers, const std::string& why) {
  Shape sh;
  OutsideLibrary& o = sh.verdict;
  o.signature = "offset even in the steering";
  o.text = "not one of my effects: the error behaves like an offset even in the steering, w(v) |d_sw| (" + numbers +
           "): the road wheels turn more to one side than to the other (a steering unequal left and right)" + why +
           ". A formula that states it, k > 0 for more to the left:";
  o.formula_template = "model:\n  formulas:\n    steering_unequal:\n      alpha_v: \"k*abs(d_sw)/is\"\n"
                       "      parameters:\n        k: {min: -0.3, max: 0.3}\n";
  return sh;
}

Shape AccelerometerEven(const std::string& numbers, const std::string& why) {
  Shape sh;
  sh.both_outputs = false;
  OutsideLibrary& o = sh.verdict;
  o.signature = "accelerometer even in a_y";
  o.text = "not one of my effects: the error behaves like an accelerometer that reads both turns shifted the same way, "
           "even in a_y (" + numbers + ")" + why +
           ": a nonlinearity of the sensor (or of its mounting). A formula that states it, k2 the reading's error at "
           "1 g in g:";
  o.formula_template = "model:\n  formulas:\n    accel_even:\n      a_y_meas: \"a_y + k2*a_y^2/9.81\"\n"
                       "      parameters:\n        k2: {min: -0.3, max: 0.3}\n";
  return sh;
}

// An even shape the data do not place: both formulas, for the ladder to judge on held-out data.
Shape EitherEven(const std::string& numbers, const std::string& carried) {
  const Shape steering = SteeringEven("", ""), accelerometer = AccelerometerEven("", "");
  Shape sh;
  sh.both_outputs = false;
  OutsideLibrary& o = sh.verdict;
  o.signature = "even in the turn";
  o.text = "not one of my effects: the error is even in the turn (" + numbers + "), and " + carried +
           ", so it does not say whether the road wheels turn more to one side or the accelerometer reads both turns "
           "shifted the same way. The formulas that state either; list both as hypotheses (--candidates "
           "+steering_unequal,+accel_even) and the ladder keeps the one the held-out drives confirm:";
  const std::string head = "model:\n  formulas:\n";
  o.formula_template = head + steering.verdict.formula_template.substr(head.size()) +
                       accelerometer.verdict.formula_template.substr(head.size());
  return sh;
}

std::optional<Shape> ShapeVerdict(const discover::Ladder& ladder) {
  if (ladder.diagnoses.empty() || ladder.rungs.empty() || ladder.diagnoses.back().model != ladder.rungs.back().model)
    return std::nullopt;
  const discover::Diagnosis& d = ladder.diagnoses.back();
  const std::vector<discover::SignatureCorrelation>& sig = d.signatures;
  if (sig.empty() || !IsShape(sig.front()) || std::abs(sig.front().z_robust) < 2.0) return std::nullopt;
  const discover::SignatureCorrelation& top = sig.front();  // by drss
  for (const auto& s : sig) {
    if (!IsShape(s) && 2.0 * s.drss > top.drss) return std::nullopt;
  }
  if (top.key == "steer_odd")
    return SteeringOdd(Fmt("r = %+.2f, robust z = %+.1f", top.correlation, top.z_robust), top.correlation < 0);
  const std::string numbers = Fmt("%s r = %+.2f, robust z = %+.1f", top.key == "a_y2" ? "a_y^2" : "w(v) |d_sw|",
                                  top.correlation, top.z_robust);
  const std::optional<Share> share = KinematicShare(top, d.kinematic_signatures);
  if (share) {
    const std::string carried = Fmt("the measured a_y - v r carries %.2f ± %.2f of it (1 for the accelerometer, 0 for the "
                                    "steering)", share->value, share->se);
    const bool accelerometer = std::abs(share->value - 1) < 2 * share->se, steering = std::abs(share->value) < 2 * share->se;
    if (accelerometer && !steering)
      return AccelerometerEven(numbers, "; " + carried + ": the accelerometer disagrees with the gyro, not the car with the steering");
    if (steering && !accelerometer)
      return SteeringEven(Fmt("r = %+.2f, robust z = %+.1f", top.correlation, top.z_robust),
                          "; " + carried + ": a_y and the yaw rate agree, so not the accelerometer");
    return EitherEven(numbers, carried);
  }
  if (top.key == "a_y2")
    return AccelerometerEven(numbers, "; without a yaw rate a steering unequal left and right (w(v) |d_sw|) is the alternative");
  return SteeringEven(Fmt("r = %+.2f, robust z = %+.1f", top.correlation, top.z_robust),
                      "; without a yaw rate an accelerometer bent evenly (a_y^2) is the alternative");
}

}  // namespace

std::vector<OutsideLibrary> JudgeOutsideLibrary(const ReplayedData& data, const discover::Ladder& ladder,
                                                const std::vector<std::string>& final_effects) {
  std::vector<OutsideLibrary> out;
  if (ladder.rungs.empty() || !ladder.rungs.back().fit.valid) return out;
  const std::optional<Shape> shape = ShapeVerdict(ladder);
  // An a_y within its noise floor's limit whose final diagnosis still finds structure that no
  // effect explains (Diagnosis::unexplained) gets the shape's verdict too: a shape can bias EG
  // before it lifts the RMSE past the limit.
  const bool structure = shape && ladder.diagnoses.back().unexplained;
  std::optional<Comparison> c;  // the signed view, read when a gain is judged
  bool named = false;           // the shape's verdict given once with its template; then a pointer
  for (const auto& v : ladder.verdicts) {
    const bool yaw = v.output != "a_y";
    if (!v.unexplained && !(structure && !yaw)) continue;
    if (shape && (shape->both_outputs || !yaw)) {
      OutsideLibrary o = shape->verdict;
      o.output = v.output;
      if (named) {
        o.text = "the same steering property reaches the " + v.output + " (the formula above states it for both outputs)";
        o.formula_template.clear();
      }
      named = true;
      out.push_back(o);
      continue;
    }
    if (!c) c = Compare(data, {FittedModel{"model", final_effects, ladder.rungs.back().fit}}, std::nullopt);
    if (yaw && !c->has_yaw_rate) continue;
    out.push_back(Judge(yaw ? c->yaw_gains : c->gains, v.output, yaw));
  }
  return out;
}

}  // namespace ndsid::desk
