// The rules that decide whether the ladder adds a refitted candidate (LadderOptions), each its
// own function: a new rule for adding an effect goes here, and is called from
// ErrorLadder::TryCandidate (error_ladder.cc).
#pragma once

#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/discover/diagnosis.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/model/effect.h"

namespace ndsid::discover {

// The a_y RMSE the ladder judges a fit by: held-out, or the training one when nothing is held out.
double HeldOutRmse(const identify::IdentificationResult& fit);
// The same for the yaw rate [rad/s].
double HeldOutYawRmse(const identify::IdentificationResult& fit);

// Both fits score both outputs with a training RMSE each: the BIC and the RMSE rule take both.
bool BothOutputsScored(const identify::IdentificationResult& before, const identify::IdentificationResult& after);

// The BIC's change from `before` to `after`, with an effective sample size (residuals are
// autocorrelated): n_eff = n / tau, tau the integrated autocorrelation time of the refit's own
// residuals (the one noise estimate, ResidualNoiseLevel = sigma^2 tau, as the covariance uses it);
// with two outputs (`both`) each output's term, on its own residuals.
struct BicChange {
  double delta = 0;  // negative: `after` better
  double n_eff = 0;  // a_y's effective samples (logged)
};
BicChange DeltaBic(const identify::IdentificationResult& before, const identify::IdentificationResult& after, bool both);

// Effect size on held-out data (the RMSE rule): a_y's held-out RMSE falls by min_relative_improvement;
// with both outputs, one output falls by that and the other does not rise by more than 1 % (a
// gyro error shows in the yaw rate, a roll in a_y). yaw_*: held-out yaw-rate RMSEs (both only).
bool HeldOutImproves(double before, double after, double yaw_before, double yaw_after, bool both,
                     double min_relative_improvement);

// A prior on a parameter the candidate adds (model.priors, or the speed scale read from a_x) that
// the refit lands more than 3 prior sd from: it stands in for another effect. The contradiction in
// words, "" when there is none.
std::string PriorContradiction(const identify::IdentificationResult& before, const identify::IdentificationResult& after,
                               const std::vector<config::ParameterPrior>& priors);

// How far a refit moves EG from the rung's fit: relative, and in the refit's sigma (Trial).
void RecordEgShift(Trial& t, const identify::IdentificationResult& before, const identify::IdentificationResult& after);

// A valid refit against the rung's fit: t's held-out RMSEs after (and both yaw rates when `both`
// outputs are scored) and its EG shift.
void RecordRefit(Trial& t, const identify::IdentificationResult& before, const identify::IdentificationResult& after, bool both);
// "held-out RMSE +x.x %", with both outputs followed by ", yaw rate +y.y %".
std::string HeldOutChangeText(const Trial& t, bool both);

// The EG-relevant rule (LadderOptions): both outputs, neither held-out RMSE rises, one falls by
// eg_relevant_min_improvement, the BIC falls, and EG moves by more than eg_relevant_shift_sigma of
// its standard error and eg_relevant_shift_rel of itself. `t` carries the held-out RMSEs, the BIC
// change and the EG shift.
bool IsEgRelevant(const Trial& t, const LadderOptions& options);

// A fit's held-out yaw-rate RMSE [rad/s] as if the yaw rate were read at whole samples. Step 0
// reads a shifted yaw rate between samples, (1-w) y_k + w y_k+1, which keeps only (1-w)^2 + w^2
// of its white noise's variance: the RMSE falls without any better model (on a drive whose
// yaw rate sat at 1.13x its noise floor, a 43 ms shift at 50 Hz lowered it 6 % through this
// alone). The variance removed, from the noise's standard deviation yaw_noise_sd (the floor of
// JudgeOutputs), is added back. yaw_shift_samples: the shift in samples (0: none).
double ComparableYawRmse(const identify::IdentificationResult& fit, double yaw_noise_sd, double yaw_shift_samples);

// The fitted outputs' relative changes of the held-out RMSE from `before` to `after`, summed: a_y's,
// and with both outputs the yaw rate's, `yaw_after` being after's ComparableYawRmse.
double HeldOutChange(const identify::IdentificationResult& before, const identify::IdentificationResult& after,
                     double yaw_after);

// Step 0's guard: the shifts are kept only when no fitted output's held-out RMSE rises by more
// than 0.2 % (the shifted data lose a few samples at the segments' ends) and the outputs'
// relative changes sum to a fall; the aligned yaw rate's RMSE is yaw_aligned, its
// ComparableYawRmse. A shift found on a failing model (an effect outside the model reads as a
// lead or lag) otherwise pre-empts the effect and makes the held-out error worse. With no drive
// held out the errors judged are the training data's, which any free shift lowers a little:
// the shifts must then lower an output's RMSE by training_margin, as an effect must
// (HeldOutImproves with the ladder's min_relative_improvement).
// "" when kept, else why not, in words.
std::string AlignmentRejection(const identify::IdentificationResult& recorded, const identify::IdentificationResult& aligned,
                               double yaw_aligned, double training_margin);

// The determination rule (LadderOptions::determined_z): the effect's parameters in `fit` (but the
// per-drive and fixed ones) are told from their neutral values. One parameter: it lies more than z
// standard errors from its neutral value. Several (a formula with a constant and a speed term):
// jointly, their Wald statistic d' R^-1 d (d the distances in standard errors, R their
// correlation) exceeds the chi-square quantile with the tail of z (ChiSquareQuantileAtZ), so a
// parameter near its neutral value beside a determined one does not reject the effect. "" when
// so, else the parameters that do not, in words.
std::string UndeterminedParameters(const model::Effect& effect, const identify::IdentificationResult& fit, double z);

// The chi-square quantile for k degrees of freedom with the tail of a two-sided normal z (z = 3:
// 0.27 %): z^2 for k = 1, else Wilson-Hilferty (within 1.5 % of the exact quantile for k = 2).
double ChiSquareQuantileAtZ(int k, double z);

// The plausibility rule: no parameter of `effect` in `fit` (but the per-drive and fixed ones)
// ended on its box. The box is the physically plausible range: a parameter the data push onto its
// edge stands in for something else (another effect, a time skew, an effect outside the library).
// "" when none, else the parameters on their bounds, in words.
std::string ParametersOnTheirBounds(const model::Effect& effect, const identify::IdentificationResult& fit);

// The determination rule and the plausibility rule together: "" when every parameter of
// `effect` in `fit` passes both, else the ones that do not, in words.
std::string ImplausibleParameters(const model::Effect& effect, const identify::IdentificationResult& fit, double z);

// Neither fitted output's held-out RMSE rises by more than 1 % from t's before to its after: the
// rule for a change the data need not confirm, only not contradict (the speed scale read from a_x,
// an effect the stops determine, an undetermined effect taken out again).
bool HeldOutHolds(const Trial& t, bool both);

}  // namespace ndsid::discover
