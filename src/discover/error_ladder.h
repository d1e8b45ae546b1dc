// The error ladder (diagnosis.h, ClimbErrorLadder) as an algorithm with named state and steps,
// in the manner of Ceres's TrustRegionMinimizer:
//   FitStartingModel   rung 0: the starting model (or the caller's fit of it)
//   AlignInTime        step 0: the roles' latencies (alignment.h); the data shifted, rung 0 refitted,
//                      unless an effect explains more than the shifts (one whose signature
//                      resembles them; LookAlikeBeatsShifts): then AddLookAlikeThenAlign adds it as rung 1 and
//                      estimates the latencies again with it in the model
//   TrySpeedScaleFirst the speed scale read from a_x: a prior on every fit, speed_scale itself first
//   ClimbOneRung       diagnose (the ranking), refit the best candidates one by one (TryCandidate,
//                      judged by trial_rules.h), add the first that passes, else the EG-relevant one
//   TryStandstillEvidence after the climb: an effect the stops determine and the model lacks
//                      (an a_y bias a steering offset has absorbed), refitted with that evidence
//   TrySteadyStateEvidence the steady-state regression's intercept the model leaves: a steering
//                      offset or an a_y bias, refitted; one that agrees added (both: the better, the other named)
//   PruneUndetermined  an added effect a later one left undetermined is taken out again
//   DiagnoseFinalModel the final model's ranking, where the steps above changed it after the climb
//   Judge              after the last rung: EG settled?, each output against its noise floor (verdicts.h)
// Every stopping rule is its own predicate: StartingFitFailed, StepLimitReached, and ClimbOneRung's
// false (nothing added: StopReason says why).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ndsid/discover/diagnosis.h"

namespace ndsid::discover {

class ErrorLadder {
 public:
  ErrorLadder(const config::IdentificationConfig& config, double wheelbase_m, const std::vector<std::string>& start_effects,
              const model::EffectLibrary& library, const identify::SegmentList& training,
              const identify::SegmentList& validation, const LadderOptions& options);

  // Runs the steps above and returns the ladder.
  Ladder Climb();

 private:
  // A refit of the current model with one more effect.
  struct Refit {
    std::vector<std::string> effects;   // the refitted model's effects
    identify::Identifier model;         // the refitted model (its drive values: the current fit's)
    identify::IdentificationResult fit; // its fit, started from the current fit
  };
  // A candidate that passed only the EG-relevant rule, kept until every candidate of the rung is
  // tried: of several, the one with the lowest BIC change is added.
  struct EgRelevant {
    size_t trial;  // index into ladder_.trials
    double dbic;   // both outputs' BIC change: the strongest evidence wins
    Refit refit;   // the refit, added as it is
  };

  // A refit judged by the ladder's rules (JudgeRefit).
  struct Judged {
    Trial trial;            // its numbers and verdict (accepted: added at once)
    bool eg_moves = false;  // not accepted, but EG-relevant (AddEgRelevant)
  };

  // The steps.
  void FitStartingModel();
  void AlignInTime();
  void AddLookAlikeThenAlign();
  void TrySpeedScaleFirst();
  bool ClimbOneRung();  // true when a rung was added
  void TryStandstillEvidence();  // error_ladder_evidence.cc, with the next
  void TrySteadyStateEvidence();
  void PruneUndetermined();
  void DiagnoseFinalModel();
  void Judge();

  // Within a rung.
  std::vector<CandidateScore> TrialOrder(const Diagnosis& diagnosis) const;
  bool IsTried(const CandidateScore& c, const Diagnosis& diagnosis, int tried, int most = 3) const;
  std::vector<std::string> EffectsWith(const std::string& effect) const;
  // The current model's ranking: the ladder's last diagnosis where it is of this model, else made
  // now and appended (so the evidence steps and DiagnoseFinalModel do not rank one model twice).
  const Diagnosis& DiagnosisOfCurrentModel();
  // An effect of the model shares a parameter with `effect` (it has it, or an alternative form).
  bool ModelHasParameterOf(const std::string& effect) const;
  // The stops' evidence on the training drives, and every prior a refit with `effect` is judged against.
  std::vector<identify::Identifier::StandstillPrior> TrainingStandstillPriors() const;
  std::vector<config::ParameterPrior> JudgingPriors(const std::string& effect) const;
  // The ladder may add `effect`: the library's candidates, or the user's list (--candidates).
  bool IsCandidate(const std::string& effect) const;
  Refit RefitWith(const std::vector<std::string>& effects) const;
  // The ladder's rules on a refit with `effect` added, against the current fit.
  Judged JudgeRefit(const std::string& effect, const Refit& r) const;
  // Refits with c.effect and records the trial; true when it is added at once. An EG-relevant
  // refit that is not is appended to `eg_relevant`.
  bool TryCandidate(const CandidateScore& c, std::vector<EgRelevant>& eg_relevant);
  void AddEgRelevant(const std::vector<EgRelevant>& eg_relevant);
  void AddRung(const Refit& refit, const std::string& added, double dbic, const std::string& removed = "");

  // Step 0 (error_ladder_step0.cc).
  // A model refitted on shifted copies of the data, and the guard's verdict.
  struct Shifted {
    std::vector<stats::Segment> training, validation;  // the shifted copies
    identify::IdentificationResult fit;                // the model refitted on them
    std::string rejected;                              // "" when the guard keeps the shifts
  };
  Shifted ShiftAndRefit(const identify::Identifier& model, const identify::IdentificationResult& from,
                        const std::vector<RoleLatency>& latencies) const;
  void UseShifted(Shifted& shifted);
  void MeasureYawNoise();
  // The data as recorded that the held-out errors are judged on (the training data when nothing is held out).
  const identify::SegmentList& RecordedHeldOut() const { return validation_in_.empty() ? training_in_ : validation_in_; }
  // fit's ComparableYawRmse (trial_rules.h) with the yaw rate shifted by `latencies`; 0 without it.
  double ComparableYaw(const identify::IdentificationResult& fit, const std::vector<RoleLatency>& latencies) const;
  // A contestant's path: the current model with the effect added on the data as recorded, then
  // the latencies estimated again with it and applied under the guard.
  struct LookAlike {
    std::string effect;
    Refit refit;                              // + effect, on the data as recorded
    double dbic = 0;                          // its BIC change there
    std::vector<RoleLatency> latencies;       // estimated with it in the model
    std::optional<Shifted> shifted;           // kept by the guard (none: the data as recorded)
    std::string rejected;                     // the guard's reason when it did not keep them
    const identify::IdentificationResult& Final() const { return shifted ? shifted->fit : refit.fit; }
  };
  // The contest: of the candidates the current model's diagnosis on the data as recorded would
  // refit, one whose refit there lowers the held-out errors by the ladder's margin and that stays
  // determined and off its bounds after its own alignment (PathWith); the winner lowers the
  // held-out errors more than the shifts alone by that margin (the outputs' relative changes
  // summed). Every contestant is recorded as a trial (step -1).
  std::optional<LookAlike> LookAlikeBeatsShifts(const identify::IdentificationResult& shifted);
  std::optional<LookAlike> PathWith(const std::string& effect, Trial& trial) const;

  // Stopping rules.
  bool StartingFitFailed() const { return !fit_.valid; }
  bool StepLimitReached(int step) const { return step >= options_.max_steps; }
  std::string StopReason(int tried) const;  // nothing added on the current rung

  // The inputs, as given.
  const config::IdentificationConfig& config_;  // the identification's configuration
  const double wheelbase_m_;                    // l [m]
  const model::EffectLibrary& library_;         // every model is built from it (the configuration's effects)
  const identify::SegmentList& training_in_;    // the data as recorded
  const identify::SegmentList& validation_in_;
  const LadderOptions& options_;

  // The state that travels between the steps.
  config::IdentificationConfig ladder_config_;  // config_ plus the speed-scale prior: every refit's
  std::vector<std::string> effects_;            // the current model's effects (the last rung's)
  identify::Identifier current_;                // the current model, set to fit_'s drive values
  identify::IdentificationResult fit_;          // its fit on training_ and validation_
  std::vector<stats::Segment> aligned_training_, aligned_validation_;  // step 0's shifted copies
  identify::SegmentList training_, validation_;  // what every fit reads: as recorded or step 0's copies
  double yaw_noise_sd_ = 0;                     // the yaw rate's noise [rad/s] (MeasureYawNoise)
  std::optional<LookAlike> look_alike_;         // step 0's contest winner, added as rung 1
  Diagnosis contest_diagnosis_;                 // the contest's ranking (rung 0's diagnosis when it wins)
  Ladder ladder_;                               // the result, built rung by rung
};

}  // namespace ndsid::discover
