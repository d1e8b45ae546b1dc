// Windowed output-error identification of the single-track model with Ceres (physics.md §1):
// each gated segment is simulated independently from its inputs (in chunks, burn-in dropped),
// the parameters p = (m, Jz, cv, ch, lv, is) are bounded by the configured box, m fixed by
// default, and the result carries EG with a standard error, the parameter correlations, the
// training and validation RMSE and an identifiability report.
#pragma once

#include <array>
#include <cstdint>
#include <map>
#include <memory>
#include <optional>
#include <set>
#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/gate/gate.h"
#include "ndsid/identify/half_estimate.h"
#include "ndsid/identify/linearized_window.h"
#include "ndsid/model/model_spec.h"
#include "ndsid/model/single_track.h"
#include "ndsid/stats/segment.h"

namespace ndsid::identify {

using SegmentList = std::vector<const stats::Segment*>;

struct ParameterEstimate {
  std::string name;
  std::string unit;
  double value = 0;
  double se = 0;          // standard error (0 when fixed)
  bool fixed = false;
  bool at_bound = false;  // ended on the box: the data push it outside the prior box (AtBound)
  double eg_correlation = 0;  // correlation of its estimate with EG's (0 when fixed)
  double eg_release_shift_rad_per_mps2 = 0;  // on a bound: EG's move were it released (Newton step)
};

// A value on its box [lower, upper], within 1e-6 of the box's width: what at_bound reports.
inline bool AtBound(double value, double lower, double upper) {
  return value <= lower + 1e-6 * (upper - lower) || value >= upper - 1e-6 * (upper - lower);
}

struct WeakDirection {
  double singular_value_ratio = 0;  // relative to the largest (scaled Jacobian)
  std::string description;          // e.g. "+0.50 m +0.50 Jz +0.50 cv +0.50 ch"
};

// "2.1.0": the Ceres Solver this was built against (`ndsid version`).
std::string CeresVersion();

struct IdentifiabilityReport {
  std::array<double, model::kNumParams> singular_values{};  // of the column-scaled Jacobian (free params)
  double condition_number = 0;
  std::vector<WeakDirection> weak;  // directions the data do not determine
  std::vector<std::string> notes;   // e.g. "m fixed from configuration: only cv/m, ch/m, Jz/m determined"
};

// One per-drive parameter's value on one drive (model::EffectParam::per_drive, e.g.
// load_change's load_ratio), estimated by Identify with the shared parameters held.
struct DriveValue {
  int64_t drive_id = 0;
  std::string param;       // the parameter's name (ModelSpec::param_name)
  double value = 0;
  double se = 0;           // conditional on the shared parameters (0 for a pinned reference)
  bool reference = false;  // the drive the parameter vector (and EG) describes
  bool validation = false; // a held-out drive (its values fitted with the shared parameters held)
};

// Per-drive values by drive id as (index in the full parameter vector, value): what a chunk of
// that drive puts in place of the vector's entries. The reference drive is not listed.
using DriveOverrides = std::map<int64_t, std::vector<std::pair<int, double>>>;
// The values laid out for `spec` (by parameter name; parameters it lacks are dropped).
DriveOverrides OverridesFor(const std::vector<DriveValue>& values, const model::ModelSpec& spec);

// How many times too low the lag-one noise floor of an output reads when its role's values come
// every `interval_s` and the fit samples at `rate_hz`: noise interpolated between frames
// P = interval_s x rate_hz fit samples apart is that much smoother. 1 at or above the fit's rate
// (and for an unknown interval). The pipeline, diagnose's verdicts and compare all scale by it.
double SlowOutputFloorFactor(double interval_s, double rate_hz);

struct IdentificationResult {
  bool valid = false;
  std::string reason;  // why not valid (no data, solver failure, non-finite)
  std::string model;  // "single-track + steer_offset + ..."
  std::array<ParameterEstimate, model::kNumParams> params{};  // base: m, Jz, cv, ch, lv, is
  std::vector<ParameterEstimate> effect_params;              // the effects' parameters, in model order
  double eg_rad_per_mps2 = 0;
  double eg_se_rad_per_mps2 = 0;
  double eg_deg_per_g = 0;
  double eg_se_deg_per_g = 0;
  // What the checks of the fit read (adequacy/fit_checks.h). sigma(EG) as the fit gave it, before
  // the halves' disagreement widened the published one (HonestSigma); the two halves (alternate
  // training drives; none with fewer than two); each output's noise floor, the white part of its
  // training residual sqrt(sum (e_k - e_k-1)^2 / 2n) (-1: unknown).
  double eg_se_fit_rad_per_mps2 = 0;
  double eg_bound_shift_rad_per_mps2 = 0;  // EG's move were every bound released (one Newton step)
  // The priors' share of EG's information, 1 - var(EG | data and priors) / var(EG | data alone),
  // both classical at the optimum (0 without priors): what the adequacy tracker counts a prior as
  // in hours of driving (docs/fleet.md, "Adequacy with a fleet prior").
  double eg_prior_info_share = 0;
  std::optional<std::pair<HalfEstimate, HalfEstimate>> halves;
  double floor_a_y_mps2 = -1;
  double floor_yaw_radps = -1;
  std::vector<double> correlation;  // row-major over all parameters (base then effects); 0 for fixed ones
  double rmse_train_mps2 = 0;        // a_y, unweighted, whatever the outputs
  double rmse_validation_mps2 = -1;  // -1: no validation data
  // Outputs fitted (identification.outputs): the yaw rate only when configured and the data
  // have one; its RMSEs are -1 otherwise. Noise levels sigma^2 tau of each output's residuals at
  // the solution (the weights were 1/sqrt of them), 0 for an output not fitted.
  bool yaw_rate_output = false;
  double rmse_train_yaw_radps = -1;
  double rmse_validation_yaw_radps = -1;
  size_t residuals_train_yaw = 0;
  double noise_level_a_y = 0;         // (m/s^2)^2 * samples
  double noise_level_yaw_rate = 0;    // (rad/s)^2 * samples
  size_t residuals_train = 0;
  size_t residuals_validation = 0;
  size_t chunks = 0;
  double train_hours = 0;
  int iterations = 0;         // the solver's iterations on the whole window (every solve)
  int coarse_iterations = 0;  // before them, on the coarse start's subset of chunks (large windows)
  bool coarse_start_used = false;  // its solution was the whole window's start (else the start was better)
  double solve_seconds = 0;
  std::string termination;
  std::string se_method;  // "cluster-robust (N chunks)" or "autocorrelation-corrected"
  IdentifiabilityReport identifiability;
  // Per-drive parameters only: every such parameter on the training drives, then the held-out ones.
  std::vector<DriveValue> drive_values;
  // How the fit was computed (docs/incremental.md): "full window", or "incremental" with the
  // chunks simulated (the new data) and those taken from the prior.
  std::string update = "full window";
  size_t chunks_simulated = 0;
  size_t chunks_from_prior = 0;
  size_t chunks_relinearized = 0;  // prior chunks relinearised in place, counted at every round
  // Held-out chunks whose RMSE sums came from the prior's quadratics (LinearizedWindow::held_out)
  // / were simulated with their Jacobian at the estimate (incremental path only).
  size_t held_out_from_prior = 0;
  size_t held_out_linearized = 0;
  // Every training chunk's quadratic at this fit's estimate (or kept from the prior): the next
  // incremental update's prior. Set when asked for (IncrementalUpdate::keep) and the fit is usable.
  std::shared_ptr<const LinearizedWindow> linearized;

  model::Params<double> AsParams() const;
  std::vector<double> AllValues() const;  // base then effect parameters (ModelSpec layout)
  // The values laid out for `spec`: the base six, effect parameters by name, a parameter this
  // result lacks at its neutral value (a fit restored from another model or an older version).
  std::vector<double> ValuesFor(const model::ModelSpec& spec) const;
  // The number of estimated quantities: the free parameters and every training drive's own
  // per-drive values (the reference drive's are the vector's).
  size_t NumEstimated() const;
};

// Incremental re-identification (docs/incremental.md): fit only the data the prior does not
// hold, plus the prior's quadratic; a segment of the prior is relinearised in place (its chunks
// simulated once at the estimate, their quadratics replaced) when the estimate lies more than
// relinearize_sigma of the prior's own standard deviation from its chunks' linearisation point,
// before or after the solve. Without a usable prior (none, or built for another model, scaling,
// chunking or outputs) the fit covers the whole window.
struct IncrementalUpdate {
  std::shared_ptr<const LinearizedWindow> prior;
  double relinearize_sigma = 5.0;
  bool keep = true;  // return the linearisation (IdentificationResult::linearized)
  // Every prior chunk relinearised until the estimate moves less than 0.05 of its standard
  // deviation from their points: the whole window's optimum and statistics without refitting it
  // from scratch (the final fit and the scheduled refits).
  bool exact = false;
};

class Identifier {
 public:
  Identifier(const config::IdentificationConfig& config, double wheelbase_m, model::ModelSpec spec = {});

  // warm_start: initial values, either the 6 base parameters (effects start at their initial
  // values) or the full vector; else the configured initial values.
  IdentificationResult Identify(const SegmentList& training, const SegmentList& validation,
                                const std::optional<std::vector<double>>& warm_start = std::nullopt) const;
  IdentificationResult Identify(const SegmentList& training, const SegmentList& validation,
                                const std::optional<model::Params<double>>& warm_start) const;
  // The same, incrementally on top of update.prior (a model with per-drive parameters is always
  // fitted whole).
  IdentificationResult Identify(const SegmentList& training, const SegmentList& validation,
                                const std::optional<std::vector<double>>& warm_start,
                                const IncrementalUpdate& update) const;

  // RMSE of the model with parameters (full vector, or base only when the model has no
  // effects) over the segments, burn-in dropped as in the fit; -1 when there are no residuals.
  double Rmse(const std::vector<double>& params, const SegmentList& segments, size_t* count = nullptr) const;
  double Rmse(const model::Params<double>& p, const SegmentList& segments, size_t* count = nullptr) const;
  // The same for the yaw rate (the modelled measured yaw rate, gyro effects included) over the
  // segments that have one; -1 when there are none.
  double RmseYawRate(const std::vector<double>& params, const SegmentList& segments, size_t* count = nullptr) const;

  // Full parameter vector: base values from p, effect parameters at their initial values.
  std::vector<double> FullVector(const model::Params<double>& p) const;
  const model::ModelSpec& spec() const { return spec_; }

  // Parameters from the configured initial values, with is and EG taken from a steady-state
  // estimate (cv adjusted so that EG matches), all clamped to the box.
  model::Params<double> WarmStart(double steer_ratio, double eg_rad_per_mps2) const;

  const config::IdentificationConfig& config() const { return config_; }
  double wheelbase_m() const { return wheelbase_m_; }

  // Per-drive parameter values used when simulating (Rmse, SimulateChunks, Diagnose). Identify
  // estimates them for a model with per-drive parameters (starting from the ones set here); set
  // them from its result before simulating. Values of parameters the model lacks are ignored.
  void set_drive_values(const std::vector<DriveValue>& values);
  const DriveOverrides& drive_overrides() const { return drive_overrides_; }
  const std::vector<DriveValue>& drive_values() const { return drive_values_; }

  // Standstill evidence (docs/two-outputs.md): the window's standstills. Identify turns those of
  // its training drives into a Gaussian prior on gyro_offset (the stops' mean yaw rate) and on
  // accel_bias (their mean a_y: bias + the cross-slope where the car stood), each with the
  // standard error of the mean over the stops, when the model has that effect and at least
  // kMinStops stops exist. Set it on a copy for a fit on another thread.
  static constexpr size_t kMinStops = 5;
  void set_standstill(std::vector<gate::StandstillStop> stops) { standstill_ = std::move(stops); }
  const std::vector<gate::StandstillStop>& standstill() const { return standstill_; }

  // One prior from the standstill evidence, as used by Identify.
  struct StandstillPrior {
    std::string param;  // gyro_offset_radps or accel_bias_mps2
    double value = 0;
    double sd = 0;
    size_t stops = 0;
    double seconds = 0;
    std::string effect;  // the library effect whose first parameter `param` is (accel_bias, gyro_offset)
  };
  // The priors the standstills of `drives` give (any drive when `drives` is empty), whatever the model.
  std::vector<StandstillPrior> StandstillPriors(const std::set<int64_t>& drives) const {
    return StandstillPriors(standstill_, drives);
  }
  static std::vector<StandstillPrior> StandstillPriors(const std::vector<gate::StandstillStop>& stops,
                                                       const std::set<int64_t>& drives);

 private:
  // The shared parameters with every drive's per-drive values held (drive_overrides_).
  IdentificationResult IdentifyAtDriveValues(const SegmentList& training, const SegmentList& validation,
                                             const std::optional<std::vector<double>>& warm_start,
                                             const IncrementalUpdate* update = nullptr) const;
  // A model with per-drive parameters: the shared fit and the per-drive fits in turn.
  IdentificationResult IdentifyPerDrive(const SegmentList& training, const SegmentList& validation,
                                        const std::optional<std::vector<double>>& warm_start) const;
  // The per-drive parameters `which` (full-vector indices) of one drive minimising its weighted
  // RSS with the other parameters held at `params` (Gauss-Newton on finite-difference
  // sensitivities, inside the parameters' boxes); se from the curvature and the noise level.
  // `weights`: the fit's output weights (a_y, yaw rate; 0: a_y alone).
  std::vector<DriveValue> FitDriveValues(const std::vector<double>& params, const SegmentList& drive_segments,
                                         int64_t drive, const std::vector<int>& which, std::vector<double> start,
                                         const std::pair<double, double>& weights) const;
  std::vector<DriveValue> drive_values_;
  DriveOverrides drive_overrides_;  // drive_values_ laid out for spec_
  std::vector<gate::StandstillStop> standstill_;
  config::IdentificationConfig config_;
  double wheelbase_m_;
  model::ModelSpec spec_;
};

}  // namespace ndsid::identify
