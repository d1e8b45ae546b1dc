// The ladder's evidence steps after the climb (error_ladder.h): what the stops and the steady
// state read, model-free, of an effect the climb did not add.
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <optional>

#include "error_ladder.h"
#include "trial_rules.h"

namespace ndsid::discover {
using identify::IdentificationResult;
using identify::Identifier;

namespace {

// The refit's implied steady-state intercept may miss the regression's by a fifth of what the
// model left of it (TrySteadyStateEvidence), as a refit may miss the stops' mean.
constexpr double kSteadyStateRelativeTolerance = 0.2;

// "added: held-out …" -> "added (evidence): held-out …": the verdict, then what it was tried on.
std::string WithEvidence(const std::string& why, const char* evidence) {
  const size_t colon = why.find(':');
  if (colon == std::string::npos) return why + " (" + evidence + ")";
  return why.substr(0, colon) + " (" + evidence + ")" + why.substr(colon);
}

// A fitted effect parameter's value, 0 where the fit has none (the effect's neutral value).
double ParamValue(const IdentificationResult& fit, const std::string& name) {
  for (const auto& p : fit.effect_params)
    if (p.name == name) return p.value;
  return 0.0;
}

}  // namespace

// The standstill evidence (docs/two-outputs.md, "Standstill evidence"): the stops' mean a_y and
// yaw rate read the accelerometer's bias and the gyro's offset, which the driving data may not
// tell from an effect already in the model. With road_bank a steering offset d0 absorbs an a_y
// bias b: the model fits d0 - is EG b and explains both outputs as well as the truth does, so no
// refit with accel_bias lowers a held-out error and its score, the stops' alone, may stay below
// the ranking's threshold. After the climb, each such effect the model lacks whose parameter the
// stops determine (their mean more than determined_z of its standard error from 0) and the model's
// parameters absorb is refitted (Identify takes the stops as a prior) and added unless a held-out
// RMSE rises by more than 1 %, its parameter is undetermined or implausible, or the refit lands
// more than 3 standard errors from the stops' value (then the stops read something else: a car
// parked on a slope).
void ErrorLadder::TryStandstillEvidence() {
  std::optional<Diagnosis> diagnosis;  // the climb's final model's, taken once some stops qualify
  for (const Identifier::StandstillPrior& sp : TrainingStandstillPriors()) {
    const std::string& effect = sp.effect;
    if (ModelHasParameterOf(effect) || !library_.Find(effect) || !IsCandidate(effect) ||
        !(std::abs(sp.value) > options_.determined_z * sp.sd))
      continue;
    // Only where the driving data cannot tell it from the model's own parameters (ScoreCandidate's
    // uniqueness below kConfoundedUniqueness): elsewhere the ranking has judged it already.
    if (!diagnosis) diagnosis = DiagnosisOfCurrentModel();
    const auto scored = std::find_if(diagnosis->ranked.begin(), diagnosis->ranked.end(),
                                     [&](const CandidateScore& c) { return c.effect == effect; });
    if (scored == diagnosis->ranked.end() || !(scored->uniqueness < kConfoundedUniqueness)) continue;
    const Refit r = RefitWith(EffectsWith(effect));
    Trial t;
    t.step = static_cast<int>(ladder_.rungs.size()) - 1;
    t.effect = effect;
    t.held_out_before = HeldOutRmse(fit_);
    char evidence[160];
    std::snprintf(evidence, sizeof evidence, "standstill evidence: %.4g +- %.2g %s over %zu stops", sp.value, sp.sd,
                  library_.Get(effect)->info().params[0].unit.c_str(), sp.stops);
    if (!r.fit.valid) {
      t.why = std::string("rejected (") + evidence + "): fit not valid: " + r.fit.reason;
    } else {
      const bool both = BothOutputsScored(fit_, r.fit);
      RecordRefit(t, fit_, r.fit, both);
      const std::string implausible = ImplausibleParameters(*library_.Get(effect), r.fit, options_.determined_z);
      double fitted = sp.value;
      for (const auto& p : r.fit.effect_params)
        if (p.name == sp.param) fitted = p.value;
      const bool agrees = std::abs(fitted - sp.value) <= 3 * sp.sd;
      t.accepted = HeldOutHolds(t, both) && implausible.empty() && agrees;
      char why[320];
      std::snprintf(why, sizeof why, "%s (%s): refit %.4g; %s; EG %+.2f %% (%+.1f sigma)", t.accepted ? "added" : "rejected",
                    evidence, fitted, HeldOutChangeText(t, both).c_str(), 100 * t.eg_shift_rel, t.eg_shift_sigma);
      t.why = why;
      if (!agrees) t.why += "; the refit contradicts the stops";
      if (!implausible.empty()) t.why += "; " + implausible;
    }
    spdlog::info("ladder: + {}: {}", effect, t.why);
    ladder_.trials.push_back(t);
    if (t.accepted) AddRung(r, effect, DeltaBic(fit_, r.fit, BothOutputsScored(fit_, r.fit)).delta);
  }
}

// The steady-state evidence (docs/two-outputs.md, "Steady-state evidence"): the steady-state
// regression (stats/steady_state.h) reads the intercept d0 of d_sw = is l r/v + is EG a_y + d0
// from the quasi-steady stretches' means, untouched by what a failing dynamic model gets wrong
// (latencies, lags, a vibrating sensor); the ranking's one-step value is taken at that failing
// fit. A model implies the intercept I = steer_offset - is EG accel_bias (its own values, 0 where
// it lacks one). Where the intercept the model leaves, d0 - I, exceeds determined_z of d0's
// standard error, it is a steering offset or an accelerometer bias: each the model lacks is
// refitted and judged by the climb's rules (JudgeRefit: a held-out error falls by the effect's
// margin, the BIC falls, its parameter determined and plausible, neither the stops nor a prior
// contradicted), and passes when besides the refit's I lies within 3 standard errors or a fifth of
// what was left of d0 (the intercept also holds what the model lacks: a dead band's share, a
// crossfall). The evidence only puts the two on the list the ranking made. One that passes is
// added; where both pass, the steady state cannot tell them apart (the stops can,
// TryStandstillEvidence): they explain the data and move EG alike, and the one with the lower
// held-out errors is added with the other named.
void ErrorLadder::TrySteadyStateEvidence() {
  const stats::SteadyStateEstimate& ss = options_.steady_state;
  const double se = ss.steer_offset_se;
  const double is_eg = ss.steer_ratio * ss.eg_rad_per_mps2;  // the intercept's a_y coefficient
  if (!ss.valid || !(se > 0)) return;
  auto implied = [&](const IdentificationResult& f) {
    return ParamValue(f, "steer_offset_rad") - is_eg * ParamValue(f, "accel_bias_mps2");
  };
  const double offset_model = ParamValue(fit_, "steer_offset_rad"), bias_model = ParamValue(fit_, "accel_bias_mps2");
  const double left = ss.steer_offset_rad - implied(fit_);  // what the model leaves of d0
  if (!(std::abs(left) > options_.determined_z * se)) return;
  const double tolerance = std::max(3 * se, kSteadyStateRelativeTolerance * std::abs(left));
  struct Reading {
    const char* effect;
    const char* param;
    double expected, sd;
  };
  std::vector<Reading> readings{{"steer_offset", "steer_offset_rad", offset_model + left, se}};
  if (std::abs(is_eg) > 0) readings.push_back({"accel_bias", "accel_bias_mps2", bias_model - left / is_eg, se / std::abs(is_eg)});
  const size_t first_trial = ladder_.trials.size();
  std::vector<std::pair<size_t, Refit>> passed;  // index into ladder_.trials, the refit
  for (const Reading& rd : readings) {
    const std::string effect = rd.effect;
    if (ModelHasParameterOf(effect) || !library_.Find(effect) || !IsCandidate(effect)) continue;
    Refit r = RefitWith(EffectsWith(effect));
    Trial t = JudgeRefit(effect, r).trial;  // the climb's rules: held-out, BIC, priors and stops, determined
    char evidence[200];
    std::snprintf(evidence, sizeof evidence, "steady-state evidence: intercept %.4g +- %.2g rad reads %s = %.4g +- %.2g %s",
                  ss.steer_offset_rad, se, rd.param, rd.expected, rd.sd, library_.Get(effect)->info().params[0].unit.c_str());
    if (r.fit.valid && !(std::abs(ss.steer_offset_rad - implied(r.fit)) <= tolerance)) {
      char why[200];
      std::snprintf(why, sizeof why, "rejected: the refit contradicts the steady state (%s = %.4g implies the intercept %.4g rad)",
                    rd.param, ParamValue(r.fit, rd.param), implied(r.fit));
      t.accepted = false;
      t.why = why;
    }
    t.why = WithEvidence(t.why, evidence);
    ladder_.trials.push_back(t);
    if (t.accepted) passed.emplace_back(ladder_.trials.size() - 1, std::move(r));
  }
  if (!passed.empty()) {
    // Both passing: the intercept is either, and the steady state cannot tell which. They explain
    // the data alike (the same intercept) and move EG alike: the one with the lower held-out
    // errors is added, the other named beside it.
    auto held_out = [&](size_t i) {
      const Trial& t = ladder_.trials[i];
      return t.held_out_after / t.held_out_before + (t.yaw_before > 0 ? t.yaw_after / t.yaw_before : 0.0);
    };
    std::sort(passed.begin(), passed.end(), [&](const auto& a, const auto& b) { return held_out(a.first) < held_out(b.first); });
    Trial& t = ladder_.trials[passed[0].first];
    for (size_t k = 1; k < passed.size(); ++k) {
      Trial& other = ladder_.trials[passed[k].first];
      other.accepted = false;
      other.why = "not " + other.why + "; " + t.effect + " explains the intercept as well (the steady state cannot tell them apart; stops can)";
      t.why += "; or " + other.effect + " (the steady state cannot tell them apart; stops can)";
    }
    const Refit& r = passed[0].second;
    AddRung(r, t.effect, DeltaBic(fit_, r.fit, BothOutputsScored(fit_, r.fit)).delta);
  }
  for (size_t i = first_trial; i < ladder_.trials.size(); ++i)
    spdlog::info("ladder: + {}: {}", ladder_.trials[i].effect, ladder_.trials[i].why);
}

}  // namespace ndsid::discover
