// Model choice (docs/monitoring.md, "model_choice"): when the window's a_y and v r disagree in
// scale (the kinematics check's model-free gain g of a_y on v r in quasi-steady turning differs
// from 1 by more than kSignificanceZ standard errors and kMinScaleDisagreement), the data alone do
// not say which sensor is off, and each attribution gives its own EG. The window is refitted with
// the disagreement attributed to each sensor in turn: its scale effect added to the model, free,
// started at the value g gives (the model-free gain is biased by beta' and the selection of
// samples, so the fit, which models both, estimates the scale):
//   accel_scale  a_meas = (1 + k_a) a_y,  k_a = g - 1 at the start
//   gyro_scale   r_meas = (1 + k_r) r,    k_r = 1/g - 1
//   speed_scale  v_meas = (1 + eps) v,    eps = 1/g - 1 (left out where a_x against dv/dt
//                decides the speed scale: determined, consistent with 0 and excluding eps)
// An alternative whose held-out RMSE of some output exceeds the published fit's by more than
// kRuledOutRmseRatio is ruled out by the data.
// Where the bus has the rear wheel speeds (signals.rear_wheel_speed_difference with
// vehicle.track_rear_m), the gyro's scale against them (stats/wheel_yaw.h) is a second trigger
// (it differs from 1 by kSignificanceZ of its sd and kMinScaleDisagreement) and a referee: it
// gives the gyro attribution a prior (k_r = s - 1), and every model, the fit as identified
// included, predicts s (accel_scale: 1; gyro_scale: 1 + k_r; speed_scale: 1/(1 + eps), the
// wheels sharing the speed's scale); one off the measured s by more than kWheelEvidenceZ of its
// sd is ruled out. When that rules out the fit as identified, the standing alternative with the
// lowest held-out a_y RMSE is published in its place (ModelChoice::published). The gyro
// attribution is refitted twice there: free with the wheels' prior, and held at their value
// (gyro_scale_at_wheels); the spread over both covers a disagreement of the two references.
// The checks of the fit (adequacy::ModelChoiceSpread) widen sigma(EG) by the spread of the rest. Only fits with the yaw rate as an output are judged
// for the scales (with a_y alone the scales are absorbed into is and EG: physics.md §4).
// Watched effects (model.watch, by default tyre_saturation): a valid full-window or exact fit runs
// each one's score test (discover::Diagnose) over the training drives; one the model lacks whose
// robust z reaches kSignificanceZ is refitted and judged as a configured alternative is, and so
// at every incremental update until the next test its EG shift is carried (WatchRequest). A tyre that saturates
// inside the gate leaves a residual near its floor and EG a few per cent (several sigma) high; the
// score test sees it where the RMSE does not.
// Configured alternatives (model.alternatives, written by `ndsid diagnose --apply` where EG is not
// settled): every valid fit, with either output, is refitted once per effect listed, added to the
// model and started at its initial values, and judged the same way (ruled out by a held-out RMSE,
// by the rear wheels through the scales it ends on); the spread covers those that stand.
#pragma once

#include <memory>
#include <optional>
#include <string>
#include <vector>

#include "ndsid/adequacy/plausibility.h"
#include "ndsid/identify/identifier.h"

namespace ndsid::pipeline {

struct WindowSnapshot;

// One attribution of the scale disagreement, refitted on the window.
struct ModelAlternative {
  std::string name;          // the effect the disagreement is attributed to: accel_scale | gyro_scale | speed_scale,
                             // or a configured alternative's effect
  double scale = 0;          // its fitted value (the attribution from the gain when not fitted); configured: the
                             // value of the effect's first parameter
  bool configured = false;   // a configured alternative (model.alternatives), not a scale attribution
  std::string parameter;     // configured: that parameter's name and unit ("lever_arm_m [m]")
  bool fitted = false;       // false: the refit failed (reason)
  std::string reason;        // why not fitted
  double eg_deg_per_g = 0, eg_se_deg_per_g = 0;
  double rmse_a_y_mps2 = -1;     // held-out (training where nothing is held out); -1: unknown
  double rmse_yaw_degps = -1;
  bool ruled_out = false;    // a held-out RMSE clearly worse than the published fit's (or not fitted)
  std::string ruled_out_why;
  // The refit itself (not written to estimate.json): published in the fit's place when the rear
  // wheels rule the fit out and this alternative stands.
  std::shared_ptr<const identify::IdentificationResult> result;
  // A watched effect (model.watch, configured set too): its score test at the fit, which made the
  // refit ("score test at the fit: z -4.4, one-step 1.61"); "" for the others.
  std::string evidence;
};

// The gyro's scale against the rear wheels, as the model choice used it.
struct WheelYawFacts {
  bool available = false;
  double scale = 0, sd = 0;  // s - 1 and its sd (with the track's tolerance)
  std::string note;
};

struct ModelChoice {
  bool judged = false;       // the disagreement was significant and the alternatives were refitted
  double gain = 0, gain_se = 0;  // the kinematics check's a_y / (v r)
  std::vector<ModelAlternative> alternatives;
  std::vector<std::string> notes;  // alternatives left out and why (e.g. the speed scale decided by a_x)
  double seconds = 0;        // the refits' wall time
  WheelYawFacts wheel_yaw;   // the rear wheels' evidence (available: false where the bus lacks it)
  std::string fit_ruled_out_why;  // non-empty: the fit as identified contradicts the rear wheels
  std::string published;     // the alternative published in the fit's place ("" = the fit as identified)
  bool watch_tested = false;  // the watched effects' score test ran at this fit (WatchRequest::test)
};

// model.watch at one fit. The score test costs a Jacobian of the whole window, more than an
// incremental update itself, so it runs at full-window and exact fits (the first, every
// identification.full_refit_every-th, the final one, every fit with incremental: false) and
// where the window's gated time has doubled since the last test (Pipeline::Watch); the
// incremental updates between carry what the last test found, not refitted: each standing
// alternative's EG shift from the fit it was judged against, added to the update's EG.
struct WatchFinding {
  ModelAlternative alternative;  // as judged at the test (its refit's result not kept)
  double eg_shift_deg_per_g = 0;  // its EG minus the tested fit's
};
struct WatchRequest {
  std::vector<std::string> effects;  // model.watch
  bool test = true;
  std::vector<WatchFinding> found;
};
// The watched effects a tested choice found standing, for the next WatchRequest::found.
std::vector<WatchFinding> WatchFound(const ModelChoice& choice, double fit_eg_deg_per_g);

// The rules above, as constants (docs/monitoring.md states them).
inline constexpr double kSignificanceZ = 3.0;            // |g - 1| / se(g)
inline constexpr double kMinScaleDisagreement = 0.005;   // |g - 1|: below, beta' and noise
inline constexpr double kRuledOutRmseRatio = 1.02;       // alternative's held-out RMSE / the fit's
inline constexpr double kWheelEvidenceZ = 3.0;           // |s_measured - s_predicted| / sd(s)
// The gyro attribution with its scale held at the rear wheels' value (beside the one fitted with
// their prior): the two references of k_r, the data's and the wheels', may disagree by more than
// the fit's sigma says, and the spread covers it.
inline constexpr const char* kHeldSuffix = "_at_wheels";

// model.alternatives against the model: each a library or formula effect, not in model.effects,
// listed once, and compatible with the model's effects (no parameter shared). Throws ConfigError.
void CheckAlternatives(const std::vector<std::string>& alternatives, const std::vector<std::string>& effects,
                       const model::EffectLibrary& library);

// model.watch against the library: each a library or formula effect, listed once. Throws
// ConfigError. One in model.effects or model.alternatives, or one that cannot be added to the
// model (it shares a parameter with an effect of it), is not tested (WatchedToTest).
void CheckWatched(const std::vector<std::string>& watched, const model::EffectLibrary& library);
std::vector<std::string> WatchedToTest(const std::vector<std::string>& watched, const model::ModelSpec& spec,
                                       const std::vector<std::string>& configured);

// Whether the window's kinematics check shows a significant scale disagreement for a fit with
// the yaw rate as an output (the gain and its se from `data_checks`' window-level kinematics).
bool ScaleDisagreement(const identify::IdentificationResult& fit, const adequacy::PlausibilityReport& data_checks,
                       double* gain = nullptr, double* gain_se = nullptr);

// Refits the snapshot once per attribution (nothing when neither the kinematics nor the rear
// wheels show a disagreement) and once per configured alternative. track_rear_m:
// vehicle.track_rear_m (0: no wheel evidence). Runs on the fit's thread; touches no pipeline state.
ModelChoice FitModelAlternatives(const identify::Identifier& identifier, const WindowSnapshot& snap,
                                 const identify::IdentificationResult& fit, const adequacy::PlausibilityReport& data_checks,
                                 double track_rear_m = 0, const std::vector<std::string>& configured = {},
                                 const WatchRequest& watch = {});

}  // namespace ndsid::pipeline
