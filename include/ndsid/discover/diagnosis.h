// Which physical effect is missing (physics.md §5). From the Jacobian at the current fit, a
// score (Lagrange-multiplier) test for every candidate effect of the library predicts the drop
// in the residual sum of squares without refitting; the effect's sensitivity is projected
// against what the fitted parameters can absorb (uniqueness near 0: confounded, and with what).
// Significance uses chunk-clustered variances (50 Hz residuals are strongly autocorrelated).
// The best candidates are then confirmed by refitting, one rung of the error ladder at a time.
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ndsid/discover/alignment.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/model/effect_library.h"
#include "ndsid/stats/speed_scale.h"
#include "ndsid/stats/steady_state.h"

namespace ndsid::discover {

struct CandidateScore {
  std::string effect;
  std::string param;
  std::string unit;
  double one_step = 0;        // Gauss-Newton estimate of the parameter from the current fit
  // Its standard error: the larger of the model-based sqrt(sigma^2 tau / I) and the cluster
  // sandwich sqrt(V) / I (I the projected information, V the variance over chunks of their scores
  // at the one-step estimate), as the fit's covariance takes the larger. 0 where not computed.
  double se = 0;
  double drss = 0;            // predicted drop of the residual sum of squares
  double rmse_predicted = 0;  // RMSE if that drop were realised
  double uniqueness = 0;      // |z~|^2 / |z|^2: the part the current parameters cannot absorb
  double z_robust = 0;        // score / its cluster-robust standard deviation
  bool significant = false;   // |z_robust| above the threshold
  std::vector<std::string> confounded_with;  // parameters / candidates it trades with
};
// Below this uniqueness the current parameters absorb a candidate: confounded_with names them.
constexpr double kConfoundedUniqueness = 0.2;

struct SignatureCorrelation {
  // Its short name: "bias", "a_y", "a_y3", "w", "w_a_y", "steer_odd" (w(v) sgn(d_sw): an offset odd
  // in the steering), "steer_even" (w(v) |d_sw|), "a_y2" (a_y^2: an accelerometer bent evenly),
  // "steer_rate", "steer_rate_v", "a_x", "a_x_a_y".
  std::string key;
  std::string signal;  // e.g. "a_y^3", "steering rate"
  double correlation = 0;
  double z_robust = 0;
  double drss = 0;     // drop if the residual were regressed on this signal alone
  // The even shapes ("a_y2", "steer_even"; 0 for the others): the residual's slope on the signal
  // with a constant, a_y, a_y^3 and w(v) sgn(d_sw) beside it, its part that nothing odd in the turn
  // takes (left and right turns are not driven alike, so an odd error leaks into an even signal's
  // correlation); and its standard error, clustered by chunk.
  double slope = 0;
  double slope_se = 0;
};

struct Diagnosis {
  std::string model;
  std::string outputs = "a_y";  // the residuals scored: "a_y", or "a_y and yaw rate" (stacked, weighted)
  double rmse = 0;              // a_y, unweighted
  size_t residuals = 0;
  // The RSS scored (with two outputs stacked, each weighted by 1/sqrt(sigma^2 tau)): every drss
  // below, the candidates' and the signatures', is a drop of it, so drss / rss is its share.
  double rss = 0;
  std::vector<CandidateScore> ranked;  // by drss, largest first
  std::vector<SignatureCorrelation> signatures;  // by drss
  // The same signals against a_y,meas - v r_meas (with a yaw rate; else empty), by drss: an a_y
  // shape found there too is the accelerometer's, one absent there the car's.
  std::vector<SignatureCorrelation> kinematic_signatures;
  bool unexplained = false;            // structure left that no candidate explains
  std::string unexplained_text;
  // Standstill evidence scored with the candidates (accel_bias, gyro_offset): the stops' mean.
  std::vector<identify::Identifier::StandstillPrior> evidence;
};

struct DiagnosisOptions {
  std::vector<std::string> candidates;  // empty: every library effect not yet in the model
  // The candidates are added to the library's default ones (--candidates +name,...) instead of
  // replacing them.
  bool candidates_extend_library = false;
  double z_threshold = 3.0;             // significance filter on the robust score statistic
  // A fitted parameter on its bound is held in the projection (the active set at the fit: a
  // refit keeps it there unless its gradient turns inward). Off: every fitted parameter is
  // projected against, as the ranking has always done.
  bool hold_on_bound = false;
};

// The fitted parameters `params` (full vector of `identifier.spec()`) over `segments`.
Diagnosis Diagnose(const identify::Identifier& identifier, const std::vector<double>& params, const identify::SegmentList& segments,
                   const DiagnosisOptions& options = {});

// One rung of the error ladder.
struct Rung {
  std::string model;
  std::string added;  // effect added at this rung ("" for the start)
  identify::IdentificationResult fit;
  double delta_bic = 0;  // vs. the previous rung (negative = better), with an effective sample size
  std::string removed;   // or an effect taken out again at this rung (the ladder's last step)
};

struct LadderOptions {
  int max_steps = 3;
  // Candidates tried by refit: significant ones, and any whose predicted RMSE is this much below
  // the current one (an effect that large is judged on held-out data, not on a noisy z).
  double large_effect_rmse_drop = 0.2;
  // Effect size, not just significance (physics.md §5): the held-out RMSE must fall at least
  // this much. 3 %: on simulated data a real 1.5 deg steering offset gives 66 %, while the
  // best spurious addition measured gave 2 %.
  double min_relative_improvement = 0.03;
  // And the added effect's parameters must be determined: each (but a per-drive one) this many of
  // its standard errors from its neutral value. An effect the data cannot tell from its absence
  // is not added, however the held-out RMSE moved (a lever arm of -0.35 +- 0.67 m standing in for
  // physics the library lacks).
  double determined_z = 3.0;
  // A second way in, with both outputs fitted and only when no candidate met the rule above: an
  // effect that changes the answer. The tracked road bank absorbs the steady part of a scale error
  // on a_y (body roll, an accelerometer scale): the model then matches both outputs with EG off by
  // the error's size, and the effect's refit lowers the held-out RMSEs by little although it is
  // determined many times over. Such a candidate is added when (all of) neither output's held-out
  // RMSE rises, one falls by at least eg_relevant_min_improvement, the BIC falls, and EG moves by
  // more than eg_relevant_shift_sigma of its standard error and more than eg_relevant_shift_rel of
  // itself (docs/two-outputs.md, "An effect that changes EG"). Of several, the lowest BIC wins.
  double eg_relevant_min_improvement = 0.01;
  double eg_relevant_shift_sigma = 5.0;
  double eg_relevant_shift_rel = 0.01;
  // The speed signal's scale read against the longitudinal accelerometer (stats/speed_scale.h),
  // from the training data; the lateral outputs cannot tell a speed scale from an accelerometer
  // scale. When available it is a prior on speed_scale in every fit of the ladder (value eps, sd
  // its prior_sd; every fit of a model with speed_scale reads the same prior from its training
  // data, docs/two-outputs.md), and when eps is more than speed_scale_add_sigma of that sd from 0,
  // speed_scale is refitted before the first rung and added unless a held-out RMSE rises by more
  // than 1 %.
  stats::SpeedScaleEvidence speed_scale_evidence;
  double speed_scale_add_sigma = 3.0;
  // The window's steady-state regression (stats/steady_state.h; the replay's, as `ndsid diagnose`
  // has it): its intercept, where the model leaves more than determined_z of its standard error of
  // it, is a steering offset or an accelerometer bias, refitted after the climb (not valid: none).
  stats::SteadyStateEstimate steady_state;
  // After the ladder: a candidate refitted at the last rung and not added that moves EG by more
  // than eg_relevant_shift_rel and this many of its standard errors leaves EG unsettled
  // (Ladder::eg_unsettled): the data do not decide between two models whose EGs differ. A refit
  // that raises a fitted output's held-out RMSE by more than eg_unsettled_rmse_ratio is one the
  // data reject (as model_choice rules such an alternative out) and does not count.
  double eg_unsettled_sigma = 3.0;
  double eg_unsettled_rmse_ratio = 1.02;
  DiagnosisOptions diagnosis;
  // Step 0 (physics.md §5): estimate each role's latency relative to a_y and climb the ladder
  // on data shifted by the significant ones.
  bool align = true;
  AlignmentOptions alignment;
  // Significant shifts compete with the effects whose signature resembles them: the candidates the
  // starting model's diagnosis on the data as recorded would refit (look_alike_contestants at
  // most, not the delays themselves; more than a rung's three, since a real latency beside the
  // look-alike ranks other candidates above it: a lever arm ranked sixth beside a 60 ms gyro
  // latency) are refitted there; one whose refit lowers the held-out errors by
  // min_relative_improvement is pursued: the latencies estimated again with it in the model. One
  // still determined and off its bounds after its own alignment, whose held-out errors then fall
  // more than the shifts' by min_relative_improvement (relative changes of both outputs summed),
  // is added first, with its own shifts (Ladder::look_alike).
  bool look_alike_contest = true;
  int look_alike_contestants = 6;
  // The window's standstills (docs/two-outputs.md): every fit and score of the ladder uses them.
  std::vector<gate::StandstillStop> standstill;
  // After the ladder stops, an output whose held-out RMSE is more than this times its noise
  // floor (the white part of its residual) is reported unexplained (OutputVerdict).
  double unexplained_ratio = 1.5;
  // ... unless its held-out RMSE is below this share of the output's spread about zero (its
  // measured root mean square): negligible whatever the floor, as the replay's explained_<output>
  // check (plausibility.rmse_negligible_spread_ratio). Noise-free data have a floor of the
  // DBC's quantisation, which a residual of 1 % of the signal exceeds many times.
  double negligible_spread_ratio = 0.05;
  // Each output's noise-floor factor for a role slower than the fit
  // (identify::SlowOutputFloorFactor of its mean frame interval; 1: at the fit's rate or faster).
  double a_y_floor_factor = 1.0;
  double yaw_floor_factor = 1.0;
  // A valid fit of the starting model on these very training and held-out segments (the
  // pipeline's own after a replay, as `ndsid diagnose` has it): the ladder starts from it instead
  // of fitting the same model again. Ignored when it is not valid or describes another model.
  std::optional<identify::IdentificationResult> start_fit;
};

// After the ladder: one output's held-out residual against its noise floor. The floor is the
// white part of the residual, sqrt(sum (e_k - e_k-1)^2 / 2n) within chunks (differencing
// removes what is smooth at 50 Hz: model error, bank, drift; a white noise's variance doubles),
// as `ndsid compare` computes it. Above `unexplained_ratio` times the floor the residual keeps
// structure that no model term explains: an effect outside the library, or a sensor whose noise
// is not white (a filtered signal's differences are small).
struct OutputVerdict {
  std::string output;  // "a_y" or "yaw rate"
  std::string unit;    // of the numbers below: "m/s^2" or "deg/s"
  double rmse = 0;     // held-out (training when nothing is held out; the text says which)
  double floor = 0;
  double ratio = 0;    // rmse / floor
  double spread = 0;   // the measured output's root mean square about zero, over the same samples
  size_t residuals = 0;
  bool unexplained = false;
  std::string text;    // the verdict in words, with the numbers
};

// The verdict for each output the fit scores (the yaw rate only when it is an output) of the
// model `identifier.spec()` at `params` over `segments`, by the limits of `options`
// (unexplained_ratio, negligible_spread_ratio, the floors' factors for roles slower than the
// fit). yaw_shift_samples: the shift step 0 applied to the measured yaw rate, in samples (0:
// none): reading it between samples averages neighbouring noise, which lowers the
// first-difference floor; the floor is corrected for it.
std::vector<OutputVerdict> JudgeOutputs(const identify::Identifier& identifier, const std::vector<double>& params,
                                        const identify::SegmentList& segments, bool yaw_rate_output,
                                        const LadderOptions& options, double yaw_shift_samples = 0, bool held_out = true);

// One candidate refitted by the ladder: what it did to the held-out error, and why it was kept
// or rejected (the stop message's "no candidate improved" lists these).
struct Trial {
  int step = 0;                 // rung it was tried on (0: the starting model)
  std::string effect;
  bool accepted = false;
  double held_out_before = 0, held_out_after = 0;          // a_y [m/s^2]
  double yaw_before = -1, yaw_after = -1;                  // yaw rate [rad/s], two outputs only
  double delta_bic = 0;
  double eg_shift_rel = 0, eg_shift_sigma = 0;  // the refit's EG against the rung's: relative, in the refit's sigma
  std::string why;              // e.g. "held-out RMSE -1.2 % (needs -3 %)", "fit not valid: ..."
  bool removal = false;         // a refit without the effect (taken out again when accepted)
};

struct Ladder {
  std::vector<Rung> rungs;
  std::vector<Trial> trials;    // every refit, in order
  std::vector<Diagnosis> diagnoses;  // the diagnosis made at each rung
  std::string stop_reason;
  std::vector<RoleLatency> alignment;      // step 0 (empty when not asked for)
  bool aligned = false;                    // some latency applied: rungs are fits on shifted data
  std::string alignment_rejected;          // significant shifts not applied, and why ("" otherwise)
  identify::IdentificationResult before_alignment;   // the aligned rung's model on the data as recorded
  // Step 0's contest (physics.md §5.0): an effect that explains more of the held-out error than
  // the shifts (one whose signature resembles them, a lever arm; or a larger error the shifts were
  // found on, a gyro offset) is added first (rung 1; diagnoses[0] is then the starting model's
  // ranking on the data as recorded), and the latencies are estimated again with it in the model.
  // Its name and the numbers of the contest ("" when the shifts won or none were significant).
  std::string look_alike, look_alike_why;
  int aligned_rung = 0;                    // the rung whose fit `aligned` refers to (1 after a look-alike)
  std::vector<OutputVerdict> verdicts;     // the final model's outputs against their noise floors
  // Empty when EG is settled; else which refits of the last rung move EG, by how much (LadderOptions).
  std::string eg_unsettled;
  std::vector<std::string> eg_unsettled_effects;  // those refits' effects (`--apply` writes them as model.alternatives)
  std::vector<std::string> final_effects;         // the last rung's model: the start, what was added, less what was taken out
};

// Step 0 (align the roles in time), then base -> + first effect -> + second ...: diagnose,
// refit with the best candidates, keep an effect when the held-out RMSE falls and BIC agrees;
// stop when nothing helps. Models are built from `library` (the configuration's effects).
Ladder ClimbErrorLadder(const config::IdentificationConfig& config, double wheelbase_m,
                        const std::vector<std::string>& start_effects, const model::EffectLibrary& library,
                        const identify::SegmentList& training,
                        const identify::SegmentList& validation, const LadderOptions& options = {});

}  // namespace ndsid::discover
