// Step 0 of the error ladder (error_ladder.h): the roles' latencies, the guard that keeps shifts
// only when they lower the held-out errors, and the contest between the shifts and the effects
// whose signature resembles a shift (a lever arm reads as an a_y lead, a tyre relaxation as a lag).
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "error_ladder.h"
#include "ndsid/identify/chunks.h"
#include "trial_rules.h"
#include "verdicts.h"

namespace ndsid::discover {
using identify::IdentificationResult;

namespace {

// The effects that are themselves the shifts step 0 estimates: not contestants.
bool IsShiftEffect(const std::string& effect) {
  return effect == "steer_delay" || effect == "gyro_delay" || effect == "speed_delay";
}

std::string ShiftsInWords(const std::vector<RoleLatency>& latencies) {
  std::string out;
  for (const RoleLatency& l : latencies) {
    if (!l.apply) continue;
    char buf[80];
    std::snprintf(buf, sizeof buf, "%s%s %+.1f ms", out.empty() ? "" : ", ", config::RoleKey(l.role), 1e3 * l.latency_s);
    out += buf;
  }
  return out;
}

}  // namespace

ErrorLadder::Shifted ErrorLadder::ShiftAndRefit(const identify::Identifier& model, const IdentificationResult& from,
                                                const std::vector<RoleLatency>& latencies) const {
  Shifted s;
  s.training = AlignSegments(training_in_, latencies);
  s.validation = AlignSegments(validation_in_, latencies);
  s.fit = model.Identify(identify::Pointers(s.training), identify::Pointers(s.validation),
                         std::optional<std::vector<double>>(from.AllValues()));
  s.rejected = s.fit.valid ? AlignmentRejection(from, s.fit, ComparableYaw(s.fit, latencies), options_.min_relative_improvement)
                           : "the model's refit on the shifted data failed: " + s.fit.reason;
  return s;
}

double ErrorLadder::ComparableYaw(const IdentificationResult& fit, const std::vector<RoleLatency>& latencies) const {
  if (!fit.yaw_rate_output) return 0.0;
  return ComparableYawRmse(fit, yaw_noise_sd_, YawShiftSamples(latencies, RecordedHeldOut()));
}

// The yaw rate's noise (its floor, JudgeOutputs) on the data as recorded, for ComparableYaw.
void ErrorLadder::MeasureYawNoise() {
  if (!fit_.yaw_rate_output) return;
  for (const OutputVerdict& v : JudgeOutputs(current_, fit_.AllValues(), RecordedHeldOut(), true, options_)) {
    if (v.output == "yaw rate") yaw_noise_sd_ = v.floor * M_PI / 180.0;
  }
}

void ErrorLadder::UseShifted(Shifted& shifted) {
  aligned_training_ = std::move(shifted.training);
  aligned_validation_ = std::move(shifted.validation);
  training_ = identify::Pointers(aligned_training_);
  validation_ = identify::Pointers(aligned_validation_);
  fit_ = shifted.fit;
  current_.set_drive_values(fit_.drive_values);
  ladder_.aligned = true;
}

// Step 0: time alignment. The ladder then works on shifted copies of the data, unless the
// starting model's refit on them fails or the guard rejects them (the data as recorded are
// kept), or a look-alike effect wins the contest (AddLookAlikeThenAlign).
void ErrorLadder::AlignInTime() {
  ladder_.before_alignment = fit_;
  ladder_.alignment = EstimateRoleLatencies(current_, fit_.AllValues(), training_in_, options_.alignment);
  const bool any = std::any_of(ladder_.alignment.begin(), ladder_.alignment.end(), [](const RoleLatency& l) { return l.apply; });
  if (!any) return;
  MeasureYawNoise();
  Shifted shifted = ShiftAndRefit(current_, fit_, ladder_.alignment);
  ladder_.alignment_rejected = shifted.rejected;
  if (shifted.rejected.empty() && options_.look_alike_contest) look_alike_ = LookAlikeBeatsShifts(shifted.fit);
  if (shifted.rejected.empty() && !look_alike_) {
    UseShifted(shifted);
    return;
  }
  if (!look_alike_) spdlog::info("step 0: shifts not applied: {}", ladder_.alignment_rejected);
  for (RoleLatency& l : ladder_.alignment) l.apply = false;
}

// One contestant's path (LookAlike); none when its refit fails or lowers the held-out errors on
// the data as recorded by less than the ladder's margin (the path, a latency search and a refit,
// is the contest's cost), or when its parameter is not
// determined (or sits on a bound) once the data are aligned for the model with it: the shifts
// then explain what it took up. The refit on the data as recorded need not pass the ladder's
// other rules (BIC, determination): those are judged on the path's end.
std::optional<ErrorLadder::LookAlike> ErrorLadder::PathWith(const std::string& effect, Trial& trial) const {
  LookAlike p{effect, RefitWith(EffectsWith(effect)), 0.0, {}, std::nullopt, ""};
  const Judged j = JudgeRefit(effect, p.refit);
  trial = j.trial;
  trial.step = -1;
  trial.accepted = false;  // added as rung 1 only when it wins
  if (!p.refit.fit.valid) return std::nullopt;
  const double first = HeldOutChange(fit_, p.refit.fit, ComparableYaw(p.refit.fit, {}));
  if (!(first < -options_.min_relative_improvement)) {
    char why[160];
    std::snprintf(why, sizeof why, "; step 0's contest: held-out change %+.1f %% on the data as recorded, not pursued", 100 * first);
    trial.why += why;
    return std::nullopt;
  }
  p.dbic = j.trial.delta_bic;
  p.latencies = EstimateRoleLatencies(p.refit.model, p.refit.fit.AllValues(), training_in_, options_.alignment);
  if (std::any_of(p.latencies.begin(), p.latencies.end(), [](const RoleLatency& l) { return l.apply; })) {
    Shifted s = ShiftAndRefit(p.refit.model, p.refit.fit, p.latencies);
    p.rejected = s.rejected;
    if (s.rejected.empty()) p.shifted = std::move(s);
  }
  if (!p.shifted) {
    for (RoleLatency& l : p.latencies) l.apply = false;
  }
  const std::string lost = ImplausibleParameters(*library_.Get(effect), p.Final(), options_.determined_z);
  if (!lost.empty()) {
    trial.why += "; step 0's contest: with its own shifts (" + ShiftsInWords(p.latencies) + ") " + lost;
    return std::nullopt;
  }
  return p;
}

std::optional<ErrorLadder::LookAlike> ErrorLadder::LookAlikeBeatsShifts(const IdentificationResult& shifted) {
  const double shifts_change = HeldOutChange(fit_, shifted, ComparableYaw(shifted, ladder_.alignment));
  contest_diagnosis_ = Diagnose(current_, fit_.AllValues(), training_in_, options_.diagnosis);
  const Diagnosis& diagnosis = contest_diagnosis_;
  std::optional<LookAlike> winner;
  double best = 0;  // the winner's change; a winner beats the shifts' by the ladder's margin (min_relative_improvement)
  int tried = 0;
  for (const CandidateScore& c : TrialOrder(diagnosis)) {
    if (IsShiftEffect(c.effect) || !IsTried(c, diagnosis, tried, options_.look_alike_contestants)) continue;
    ++tried;
    Trial trial;
    std::optional<LookAlike> path = PathWith(c.effect, trial);
    const double change = path ? HeldOutChange(fit_, path->Final(), ComparableYaw(path->Final(), path->latencies)) : 0.0;
    const bool wins = path && change < shifts_change - options_.min_relative_improvement && (!winner || change < best);
    if (path) {
      char why[240];
      std::snprintf(why, sizeof why, "; step 0's contest: with it%s%s held-out change %+.1f %% against the shifts' %+.1f %% (%s)",
                    path->shifted ? " and its own shifts " : "", path->shifted ? ShiftsInWords(path->latencies).c_str() : "",
                    100 * change, 100 * shifts_change, wins ? "explains more" : "not by the ladder's margin");
      trial.why += why;
    }
    ladder_.trials.push_back(trial);
    if (!wins) continue;
    best = change;
    char buf[300];
    std::snprintf(buf, sizeof buf, "held-out a_y and yaw-rate RMSE changes summed: %+.1f %% with %s%s%s, %+.1f %% with the shifts %s",
                  100 * change, c.effect.c_str(), path->shifted ? " and " : "", path->shifted ? ShiftsInWords(path->latencies).c_str() : "",
                  100 * shifts_change, ShiftsInWords(ladder_.alignment).c_str());
    ladder_.look_alike = c.effect;
    ladder_.look_alike_why = buf;
    winner = std::move(path);
  }
  return winner;
}

// The contest's winner becomes rung 1 (on the data as recorded), then the data are shifted by
// the latencies estimated with it in the model, when the guard kept them.
void ErrorLadder::AddLookAlikeThenAlign() {
  LookAlike& w = *look_alike_;
  for (Trial& t : ladder_.trials) {
    if (t.step == -1 && t.effect == w.effect) t.accepted = true;
  }
  ladder_.diagnoses.push_back(contest_diagnosis_);  // rung 0's diagnosis: the starting model on the data as recorded
  AddRung(w.refit, w.effect, w.dbic);
  spdlog::info("step 0: {} added before the shifts, it explains more of the held-out error ({})", w.effect, ladder_.look_alike_why);
  ladder_.before_alignment = fit_;
  ladder_.alignment = w.latencies;
  ladder_.alignment_rejected = w.rejected;
  if (w.shifted) {
    UseShifted(*w.shifted);
    ladder_.aligned_rung = static_cast<int>(ladder_.rungs.size()) - 1;
    ladder_.rungs.back().fit = fit_;
  }
  look_alike_.reset();
}

}  // namespace ndsid::discover
