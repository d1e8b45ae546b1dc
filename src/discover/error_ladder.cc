#include "error_ladder.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <set>

#include "ndsid/identify/chunks.h"
#include "scoring_model.h"
#include "trial_rules.h"
#include "verdicts.h"

namespace ndsid::discover {
using identify::IdentificationResult;
using identify::Identifier;

namespace {

// A refit further than this share of the stops' mean from it (and 3 of their standard errors)
// contradicts them (ErrorLadder::JudgingPriors).
constexpr double kStopsRelativeTolerance = 0.2;

// Why a refitted candidate was added or rejected (Trial::why); t carries its numbers.
std::string ExplainTrial(const Trial& t, bool better, bool both, bool eg_moves, const std::string& contradicts,
                         double min_relative_improvement) {
  char why[320];
  const double rel = 100 * (t.held_out_after / t.held_out_before - 1);
  if (t.accepted) {
    std::snprintf(why, sizeof why, "added: held-out RMSE %+.1f %%, dBIC %.1f", rel, t.delta_bic);
  } else if (!better) {
    std::snprintf(why, sizeof why, "rejected: held-out RMSE %+.1f %% (needs %+.1f %%%s)", rel, -100 * min_relative_improvement,
                  both ? " on one output, the other <= +1 %" : "");
  } else {
    std::snprintf(why, sizeof why, "rejected: dBIC %+.1f (needs < 0) although the held-out RMSE fell %+.1f %%", t.delta_bic, rel);
  }
  std::string text = why;
  if (!contradicts.empty()) text = "rejected: it contradicts its prior, " + contradicts;
  if (both && !t.accepted) {
    std::snprintf(why, sizeof why, "; EG %+.2f %% (%+.1f sigma)%s", 100 * t.eg_shift_rel, t.eg_shift_sigma,
                  eg_moves ? ", held-out falls and EG moves: EG-relevant" : "");
    text += why;
  }
  return text;
}

}  // namespace

ErrorLadder::ErrorLadder(const config::IdentificationConfig& config, double wheelbase_m,
                         const std::vector<std::string>& start_effects, const model::EffectLibrary& library,
                         const identify::SegmentList& training, const identify::SegmentList& validation,
                         const LadderOptions& options)
    : config_(config),
      wheelbase_m_(wheelbase_m),
      library_(library),
      training_in_(training),
      validation_in_(validation),
      options_(options),
      ladder_config_(config),
      effects_(start_effects),
      current_(config, wheelbase_m, model::ModelSpec::FromNames(start_effects, library)),
      training_(training),
      validation_(validation) {
  current_.set_standstill(options.standstill);
}

Ladder ErrorLadder::Climb() {
  FitStartingModel();
  if (StartingFitFailed()) {
    ladder_.rungs.push_back({current_.spec().Describe(), "", fit_, 0.0, ""});
    ladder_.stop_reason = "the starting model could not be fitted: " + fit_.reason;
    ladder_.final_effects = effects_;
    return std::move(ladder_);
  }
  if (options_.align) AlignInTime();
  ladder_.rungs.push_back({current_.spec().Describe(), "", fit_, 0.0, ""});
  if (look_alike_) AddLookAlikeThenAlign();
  TrySpeedScaleFirst();
  for (int step = 0; !StepLimitReached(step); ++step) {
    if (!ClimbOneRung()) break;
  }
  if (ladder_.stop_reason.empty()) ladder_.stop_reason = "step limit reached";
  TryStandstillEvidence();
  TrySteadyStateEvidence();
  PruneUndetermined();
  DiagnoseFinalModel();
  ladder_.final_effects = effects_;
  Judge();
  return std::move(ladder_);
}

void ErrorLadder::FitStartingModel() {
  const bool given = options_.start_fit && options_.start_fit->valid && options_.start_fit->model == current_.spec().Describe();
  fit_ = given ? *options_.start_fit : current_.Identify(training_in_, validation_in_, std::optional<std::vector<double>>{});
  current_.set_drive_values(fit_.drive_values);
}

// The speed scale read from a_x (LadderOptions::speed_scale_evidence): a prior on speed_scale
// for every fit below, and speed_scale itself first when the evidence says the speed is scaled.
void ErrorLadder::TrySpeedScaleFirst() {
  const stats::SpeedScaleEvidence& sse = options_.speed_scale_evidence;
  const bool has_speed_prior = std::any_of(config_.priors.begin(), config_.priors.end(),
                                           [](const config::ParameterPrior& p) { return p.name == "speed_scale"; });
  if (!sse.available || has_speed_prior) return;
  const double sd = sse.prior_sd;
  ladder_config_.priors.push_back({"speed_scale", sse.scale, sd, "the speed signal against a_x (ndsid diagnose)"});
  const bool in_model = std::find(effects_.begin(), effects_.end(), "speed_scale") != effects_.end();
  if (!IsCandidate("speed_scale") || in_model || !library_.Find("speed_scale") || !(std::abs(sse.scale) > options_.speed_scale_add_sigma * sd)) return;
  std::vector<std::string> trial = effects_;
  trial.push_back("speed_scale");
  const Refit r = RefitWith(trial);
  const IdentificationResult& f2 = r.fit;
  Trial t;
  t.step = 0;
  t.effect = "speed_scale";
  t.held_out_before = HeldOutRmse(fit_);
  char why[320];
  if (!f2.valid) {
    t.why = "fit not valid: " + f2.reason;
  } else {
    const bool both = fit_.yaw_rate_output && f2.yaw_rate_output;
    RecordRefit(t, fit_, f2, both);
    t.accepted = HeldOutHolds(t, both);
    std::snprintf(why, sizeof why, "%s (evidence from a_x: %+.2f +- %.2f %%, prior sd %.2f %%): %s; EG %+.2f %% (%+.1f sigma)",
                  t.accepted ? "added" : "rejected, a held-out RMSE rose by more than 1 %", 100 * sse.scale, 100 * sse.se,
                  100 * sd, HeldOutChangeText(t, both).c_str(), 100 * t.eg_shift_rel, t.eg_shift_sigma);
    t.why = why;
  }
  spdlog::info("ladder: + speed_scale: {}", t.why);
  ladder_.trials.push_back(t);
  if (t.accepted) AddRung(r, "speed_scale", 0.0);
}

// After the climb: an effect the ladder added whose parameters a later one has left undetermined
// or on a bound (a crossfall added before the steering offset and the bias it stood in for) is
// taken out again when the refit without it raises no held-out RMSE by more than 1 %; the newest
// first, once each.
void ErrorLadder::PruneUndetermined() {
  std::vector<std::string> added;
  for (size_t i = 1; i < ladder_.rungs.size(); ++i)
    if (!ladder_.rungs[i].added.empty()) added.push_back(ladder_.rungs[i].added);
  for (auto it = added.rbegin(); it != added.rend(); ++it) {
    const std::string effect = *it;
    const std::string undetermined = ImplausibleParameters(*library_.Get(effect), fit_, options_.determined_z);
    if (undetermined.empty() || std::find(effects_.begin(), effects_.end(), effect) == effects_.end()) continue;
    std::vector<std::string> without;
    for (const std::string& e : effects_)
      if (e != effect) without.push_back(e);
    const Refit r = RefitWith(without);
    Trial t;
    t.step = static_cast<int>(ladder_.rungs.size()) - 1;
    t.effect = effect;
    t.removal = true;
    t.held_out_before = HeldOutRmse(fit_);
    if (!r.fit.valid) {
      t.why = "kept although " + undetermined + ": the fit without it is not valid: " + r.fit.reason;
    } else {
      const bool both = BothOutputsScored(fit_, r.fit);
      RecordRefit(t, fit_, r.fit, both);
      t.accepted = HeldOutHolds(t, both);
      char why[200];
      std::snprintf(why, sizeof why, "without it: %s; EG %+.2f %% (%+.1f sigma)", HeldOutChangeText(t, both).c_str(),
                    100 * t.eg_shift_rel, t.eg_shift_sigma);
      t.why = (t.accepted ? "taken out again (" : "kept although (") + undetermined + "): " + why;
    }
    spdlog::info("ladder: - {}: {}", effect, t.why);
    ladder_.trials.push_back(t);
    if (t.accepted) AddRung(r, "", DeltaBic(fit_, r.fit, BothOutputsScored(fit_, r.fit)).delta, effect);
  }
}

// The ranking of the model the ladder ends with, where the evidence steps or the pruning changed
// it after the climb's last diagnosis: what is said after the ladder (the residual's shape,
// desk/outside_library.h) reads the final model's residual, not the one before its last rung.
void ErrorLadder::DiagnoseFinalModel() { DiagnosisOfCurrentModel(); }

const Diagnosis& ErrorLadder::DiagnosisOfCurrentModel() {
  if (ladder_.diagnoses.empty() || ladder_.diagnoses.back().model != current_.spec().Describe())
    ladder_.diagnoses.push_back(Diagnose(current_, fit_.AllValues(), training_, options_.diagnosis));
  return ladder_.diagnoses.back();
}

bool ErrorLadder::ModelHasParameterOf(const std::string& effect) const {
  return std::any_of(effects_.begin(), effects_.end(), [&](const std::string& e) { return SharesParameter(library_, e, effect); });
}

bool ErrorLadder::ClimbOneRung() {
  const Diagnosis diagnosis = Diagnose(current_, fit_.AllValues(), training_, options_.diagnosis);
  ladder_.diagnoses.push_back(diagnosis);
  int tried = 0;
  std::vector<EgRelevant> eg_relevant;
  for (const CandidateScore& c : TrialOrder(diagnosis)) {
    if (!IsTried(c, diagnosis, tried)) continue;
    ++tried;
    if (TryCandidate(c, eg_relevant)) return true;
  }
  if (!eg_relevant.empty()) {
    AddEgRelevant(eg_relevant);
    return true;
  }
  ladder_.stop_reason = StopReason(tried);
  return false;
}

// The ranking's order, with alternatives: a global form (gyro_offset) whose per-drive form's
// spread between drives is significant is followed at once by that per-drive form. The global
// one is tried first: its refit is judged on held-out drives, and when the quantity differs
// between drives a value for all makes those drives worse; then the per-drive form, which fits
// theirs. (Ranked by its spread alone, the per-drive form can come too late: its spread is only
// clean once the common value is fitted.)
std::vector<CandidateScore> ErrorLadder::TrialOrder(const Diagnosis& diagnosis) const {
  auto per_drive_form = [&](const std::string& e) {
    for (const auto& p : library_.Get(e)->info().params)
      if (p.per_drive) return true;
    return false;
  };
  auto listed = [](const std::vector<CandidateScore>& order, const std::string& effect) {
    return std::any_of(order.begin(), order.end(), [&](const CandidateScore& o) { return o.effect == effect; });
  };
  std::vector<CandidateScore> order;
  for (const CandidateScore& c : diagnosis.ranked) {
    if (listed(order, c.effect)) continue;
    order.push_back(c);
    if (!c.significant || per_drive_form(c.effect)) continue;
    for (const CandidateScore& a : diagnosis.ranked) {
      if (a.significant && per_drive_form(a.effect) && SharesParameter(library_, a.effect, c.effect) && !listed(order, a.effect))
        order.push_back(a);
    }
  }
  return order;
}

// Refitted: a significant candidate, or one whose predicted RMSE is large_effect_rmse_drop below
// the rung's (judged on held-out data, not on a noisy z), and the ranking's first whatever its
// score; three at most per rung. The first because the one-step score holds the other parameters
// where the current fit put them, which have absorbed part of the effect: a lever arm (99 %
// absorbable by lv and Jz) ranked first with z -2.7 and a predicted RMSE 1.7 % lower, and its
// refit lowered the held-out RMSE by 19 %. The ladder's rules judge the refit as any other.
// A candidate the user added to the library's (--candidates +name) is the engineer's hypothesis:
// refitted whatever its score.
bool ErrorLadder::IsTried(const CandidateScore& c, const Diagnosis& diagnosis, int tried, int most) const {
  const bool large = c.rmse_predicted < (1.0 - options_.large_effect_rmse_drop) * diagnosis.rmse;
  const bool first = !diagnosis.ranked.empty() && diagnosis.ranked.front().effect == c.effect;
  const auto& listed = options_.diagnosis.candidates;
  const bool hypothesis = options_.diagnosis.candidates_extend_library &&
                          std::find(listed.begin(), listed.end(), c.effect) != listed.end();
  return (c.significant || large || first || hypothesis) && tried < most;
}

std::vector<Identifier::StandstillPrior> ErrorLadder::TrainingStandstillPriors() const {
  std::set<int64_t> drives;
  for (const stats::Segment* s : training_) drives.insert(s->drive_id);
  return Identifier::StandstillPriors(options_.standstill, drives);
}

// The configured priors, the speed scale's from a_x, and the stops' (as Identify uses them on
// the training drives), for PriorContradiction on a refit with `effect`: a candidate whose refit
// lands far from what the stops read stands in for another effect (an a_y bias taking up a
// steering offset). Far: more than 3 of the stops' standard errors and more than a fifth of their
// mean. The stops' standard error alone can be far smaller than what the rest of a model that
// still lacks an effect pulls a real one by (a gyro offset beside a steering offset not yet
// added), which is no contradiction.
std::vector<config::ParameterPrior> ErrorLadder::JudgingPriors(const std::string& effect) const {
  std::vector<config::ParameterPrior> priors = ladder_config_.priors;
  const auto& params = library_.Get(effect)->info().params;
  for (const Identifier::StandstillPrior& sp : TrainingStandstillPriors()) {
    // A per-drive form (gyro_offset_per_drive) reports its reference drive's value, not the pooled stops'.
    if (std::any_of(params.begin(), params.end(), [&](const auto& p) { return p.name == sp.param && p.per_drive; })) continue;
    const bool configured = std::any_of(priors.begin(), priors.end(), [&](const config::ParameterPrior& p) { return p.name == sp.param; });
    char where[128];
    std::snprintf(where, sizeof where, "the mean over %zu stops, standard error %.2g", sp.stops, sp.sd);
    if (!configured) priors.push_back({sp.param, sp.value, std::max(sp.sd, kStopsRelativeTolerance * std::abs(sp.value) / 3), where});
  }
  return priors;
}

bool ErrorLadder::IsCandidate(const std::string& effect) const {
  const auto& cands = options_.diagnosis.candidates;
  return cands.empty() || options_.diagnosis.candidates_extend_library || std::find(cands.begin(), cands.end(), effect) != cands.end();
}

// The current effects with `effect` added; an alternative of an effect in the model
// (gyro_offset_per_drive for gyro_offset) replaces it.
std::vector<std::string> ErrorLadder::EffectsWith(const std::string& effect) const {
  std::vector<std::string> trial;
  for (const std::string& e : effects_)
    if (!SharesParameter(library_, e, effect)) trial.push_back(e);
  trial.push_back(effect);
  return trial;
}

// The model of `effects` refitted from the current fit, as every trial is.
ErrorLadder::Refit ErrorLadder::RefitWith(const std::vector<std::string>& effects) const {
  Identifier next(ladder_config_, wheelbase_m_, model::ModelSpec::FromNames(effects, library_));
  next.set_standstill(options_.standstill);
  next.set_drive_values(fit_.drive_values);  // per-drive parameters: start from the current values
  IdentificationResult f2 =
      next.Identify(training_, validation_, std::optional<std::vector<double>>(identify::Extend(current_.spec(), fit_.AllValues(), next.spec())));
  return Refit{effects, std::move(next), std::move(f2)};
}

// The ladder's rules on one refit with `effect` added, against the current fit: the trial with its
// verdict (accepted: added at once), and whether it is EG-relevant instead.
ErrorLadder::Judged ErrorLadder::JudgeRefit(const std::string& effect, const Refit& r) const {
  const IdentificationResult& f2 = r.fit;
  Judged j;
  Trial& t = j.trial;
  t.step = static_cast<int>(ladder_.rungs.size()) - 1;  // the rung refitted on
  t.effect = effect;
  t.held_out_before = HeldOutRmse(fit_);
  if (!f2.valid) {
    t.why = "fit not valid: " + f2.reason;
    return j;
  }
  const double before = HeldOutRmse(fit_), after = HeldOutRmse(f2);
  const bool both = BothOutputsScored(fit_, f2);
  const BicChange bic = DeltaBic(fit_, f2, both);
  spdlog::debug("ladder: + {}: effective samples {:.0f} (tau {:.1f})", effect, bic.n_eff,
                static_cast<double>(f2.residuals_train) / std::max(bic.n_eff, 1.0));
  const double dbic = bic.delta;
  double yb = 0, ya = 0;
  if (both) {
    yb = HeldOutYawRmse(fit_), ya = HeldOutYawRmse(f2);
    spdlog::info("ladder: + {}: held-out yaw-rate RMSE {:.4f} -> {:.4f} deg/s", effect, yb * 180 / M_PI, ya * 180 / M_PI);
  }
  bool better = HeldOutImproves(before, after, yb, ya, both, options_.min_relative_improvement);
  spdlog::info("ladder: + {}: held-out RMSE {:.4f} -> {:.4f}, dBIC {:.1f}", effect, before, after, dbic);
  t.held_out_after = after;
  t.delta_bic = dbic;
  if (both) t.yaw_before = yb, t.yaw_after = ya;
  const std::string contradicts = PriorContradiction(fit_, f2, JudgingPriors(effect));
  if (!contradicts.empty()) better = false;
  const std::string implausible = ImplausibleParameters(*library_.Get(effect), f2, options_.determined_z);
  const bool on_bound = !ParametersOnTheirBounds(*library_.Get(effect), f2).empty();
  t.accepted = better && dbic < 0 && implausible.empty();
  RecordEgShift(t, fit_, f2);
  j.eg_moves = both && !t.accepted && contradicts.empty() && !on_bound && IsEgRelevant(t, options_);
  t.why = ExplainTrial(t, better, both, j.eg_moves, contradicts, options_.min_relative_improvement);
  if (better && dbic < 0 && !implausible.empty()) {
    char why[160];
    std::snprintf(why, sizeof why, " (held-out RMSE %+.1f %%, dBIC %.1f)", 100 * (after / before - 1), dbic);
    t.why = "rejected: " + implausible + why;
  }
  return j;
}

bool ErrorLadder::TryCandidate(const CandidateScore& c, std::vector<EgRelevant>& eg_relevant) {
  const Refit r = RefitWith(EffectsWith(c.effect));
  const Judged j = JudgeRefit(c.effect, r);
  ladder_.trials.push_back(j.trial);
  if (j.eg_moves) eg_relevant.push_back({ladder_.trials.size() - 1, j.trial.delta_bic, r});
  if (!j.trial.accepted) return false;
  AddRung(r, c.effect, j.trial.delta_bic);
  return true;
}

// No candidate met the RMSE rule; one moves EG far beyond its uncertainty while both held-out
// errors fall. Members of a confounded group (roll, the sensor scales) can all pass; the one the
// training data of both outputs support most (lowest BIC) is added.
void ErrorLadder::AddEgRelevant(const std::vector<EgRelevant>& eg_relevant) {
  const auto best = std::min_element(eg_relevant.begin(), eg_relevant.end(),
                                     [](const EgRelevant& a, const EgRelevant& b) { return a.dbic < b.dbic; });
  Trial& t = ladder_.trials[best->trial];
  t.accepted = true;
  char why[320];
  std::snprintf(why, sizeof why, "added (EG-relevant): held-out RMSE %+.1f %%, yaw rate %+.1f %%, dBIC %.1f; EG %+.2f %% (%+.1f sigma)",
                100 * (t.held_out_after / t.held_out_before - 1), 100 * (t.yaw_after / t.yaw_before - 1), t.delta_bic,
                100 * t.eg_shift_rel, t.eg_shift_sigma);
  t.why = why;
  spdlog::info("ladder: + {}: {}", t.effect, t.why);
  AddRung(best->refit, t.effect, t.delta_bic);
}

// A refit becomes the ladder's next rung: with `added`, or without `removed`.
void ErrorLadder::AddRung(const Refit& refit, const std::string& added, double dbic, const std::string& removed) {
  effects_ = refit.effects;
  current_ = refit.model;
  fit_ = refit.fit;
  current_.set_drive_values(fit_.drive_values);
  ladder_.rungs.push_back({current_.spec().Describe(), added, fit_, dbic, removed});
}

std::string ErrorLadder::StopReason(int tried) const {
  if (tried == 0) return "no significant candidate left";
  std::string reason = "no candidate improved the held-out RMSE enough (tried:";
  for (const Trial& t : ladder_.trials)
    if (t.step == static_cast<int>(ladder_.rungs.size()) - 1) reason += " " + t.effect + (&t == &ladder_.trials.back() ? "" : ",");
  return reason + ")";
}

void ErrorLadder::Judge() {
  ladder_.eg_unsettled = DescribeUnsettledEg(ladder_, options_);
  std::vector<std::string>& unsettled = ladder_.eg_unsettled_effects;
  for (const Trial* t : TrialsLeavingEgUnsettled(ladder_, options_))
    if (std::find(unsettled.begin(), unsettled.end(), t->effect) == unsettled.end()) unsettled.push_back(t->effect);
  if (!ladder_.eg_unsettled.empty()) spdlog::warn("ladder: {}", ladder_.eg_unsettled);
  const identify::SegmentList& judged = validation_.empty() ? training_ : validation_;
  ladder_.verdicts = JudgeOutputs(current_, fit_.AllValues(), judged, fit_.yaw_rate_output, options_,
                                  YawShiftSamples(ladder_.alignment, judged), !validation_.empty());
  for (const OutputVerdict& v : ladder_.verdicts) spdlog::info("ladder: {}", v.text);
}

Ladder ClimbErrorLadder(const config::IdentificationConfig& config, double wheelbase_m,
                        const std::vector<std::string>& start_effects, const model::EffectLibrary& library,
                        const identify::SegmentList& training, const identify::SegmentList& validation,
                        const LadderOptions& options) {
  return ErrorLadder(config, wheelbase_m, start_effects, library, training, validation, options).Climb();
}

}  // namespace ndsid::discover
