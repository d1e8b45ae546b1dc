// Validity from the fit: besides the data checks (plausibility.h), whether the fit itself can be
// trusted (docs/monitoring.md, "Checks of the fit"). A fit converges somewhere on almost any data;
// these checks ask whether it converged, whether the model explains what it was fitted to, whether
// the box rather than the data set EG, and whether EG holds up against two estimates the fit did
// not use:
//   converged     the solver ended on its convergence test (not its iteration cap, not failed)
//   explained     each fitted output's held-out RMSE against its noise floor (the white part of
//                 its residual) and against the output's own spread about zero
//   bounds        the box does not set EG: released, the bounds it holds parameters on would
//                 move EG by at most a sigma (one Newton step from the estimate)
//   steady_state  the dynamic EG against the closed-form steady-state EG, within their combined
//                 sigma and the regression's known bias
//   halves        the EGs of two disjoint halves of the window (alternate drives) within their
//                 combined sigma
//   model_choice  where a_y and v r disagree in scale, EG's spread over the attributions of the
//                 disagreement to each sensor (pipeline/model_choice.h) against |EG|; the
//                 published sigma(EG) is widened to cover it (WidenedSigma)
// Each check is a Check of the estimate's PlausibilityReport, with its numbers in words, passed,
// failed or skipped (too little data to judge).
#pragma once

#include <optional>
#include <string>
#include <vector>

#include "ndsid/adequacy/plausibility.h"
#include "ndsid/config/config.h"

namespace ndsid::adequacy {

// One fitted output at the estimate. Numbers in the output's display unit (m/s^2, deg/s).
struct OutputFacts {
  std::string output;      // "a_y" | "yaw_rate"
  std::string unit;        // "m/s^2" | "deg/s"
  double rmse = -1;        // held-out RMSE (training where nothing is held out); < 0: unknown
  double floor = -1;       // white part of the residual, sqrt(sum (e_k - e_k-1)^2 / 2n); < 0: unknown
  double spread = -1;      // the measured output's root mean square about zero; < 0: unknown
  size_t residuals = 0;    // behind the RMSE
};

// A free parameter that ended on its bound, and how much EG depends on it.
struct BoundFacts {
  std::string name;
  double value = 0;
  double eg_correlation = 0;        // correlation of the parameter's estimate with EG's (covariance)
  double eg_shift_deg_per_g = 0;    // EG's move were this bound alone released
};

// EG of one half of the window, fitted on its own.
struct HalfFacts {
  bool valid = false;
  std::string reason;      // why not valid
  double eg_deg_per_g = 0, eg_se_deg_per_g = 0;
  int drives = 0;
  size_t chunks = 0;
  bool in_time = false;  // a single drive's earlier or later gated time (else alternate drives)
};

// One attribution of a kinematic scale disagreement to a sensor, refitted with its scale free, or
// a configured alternative (model.alternatives) refitted added to the model.
struct AlternativeFacts {
  std::string name;          // accel_scale | gyro_scale | speed_scale, or the configured effect
  double scale = 0;          // the scale the refit ended on; configured: its first parameter's value
  bool configured = false;
  std::string parameter;     // configured: that parameter's name and unit
  std::string evidence;      // a watched effect (model.watch): the score test that made the refit
  double eg_deg_per_g = 0, eg_se_deg_per_g = 0;
  bool ruled_out = false;    // the data contradict it (its held-out RMSE), why in ruled_out_why
  std::string ruled_out_why;
};

struct ModelChoiceFacts {
  double gain = 0, gain_se = 0;  // a_y / (v r) in quasi-steady turning
  double eg_se_published_deg_per_g = 0;  // sigma(EG) as published before the widening
  std::vector<AlternativeFacts> alternatives;
  std::vector<std::string> notes;  // attributions left out, and why
  std::string wheel_note;          // the gyro's scale against the rear wheels ("" where the bus lacks them)
  std::string fit_ruled_out_why;   // the fit as identified contradicts the rear wheels
  std::string published;           // the alternative published in its place ("" = none)
};

struct FitFacts {
  std::string termination;       // the solver's termination type (CONVERGENCE, NO_CONVERGENCE, ...)
  int iterations = 0;
  std::vector<OutputFacts> outputs;
  std::vector<BoundFacts> at_bound;
  double eg_bound_shift_deg_per_g = 0;  // EG's move were every bound released
  double eg_deg_per_g = 0, eg_se_deg_per_g = 0;
  bool steady_state_valid = false;
  double steady_state_eg_deg_per_g = 0, steady_state_eg_se_deg_per_g = 0;
  std::optional<std::pair<HalfFacts, HalfFacts>> halves;  // none: not fitted (too few drives)
  int window_drives = 0;
  size_t halves_min_chunks = 0;  // the fewest chunks each half needs (identify::kClusterRobustMinChunks)
  std::optional<ModelChoiceFacts> model_choice;  // none: not judged (a_y and v r agree in scale)
};

// EG's spread over the published EG and the alternatives not ruled out [deg/g] (max - min; 0
// without alternatives), and sigma(EG) widened to cover it: sqrt(sigma^2 + spread^2) (an
// alternative the data do not rule out lies within one widened sigma of the published EG).
double ModelChoiceSpread(double eg_deg_per_g, const ModelChoiceFacts& m);
double WidenedSigma(double eg_se_deg_per_g, double spread_deg_per_g);

// The checks, appended to report.checks in the order above (one "explained" check per output;
// model_choice only when judged).
void CheckFit(const FitFacts& facts, const config::PlausibilityConfig& limits, PlausibilityReport& report);

// The floor of a residual series from its sums: sum e_k^2 (s0), sum e_k e_k-1 (s1) over n pairs:
// sum (e_k - e_k-1)^2 = 2 (s0 - s1) up to the ends, so floor = sqrt((s0 - s1) / n).
double FloorFromSums(double s0, double s1, double n);

}  // namespace ndsid::adequacy
