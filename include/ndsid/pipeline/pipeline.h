// The whole estimator, composed: frames -> roles -> synchronised samples -> gate -> statistics
// and window -> (periodically) identification -> adequacy. Shared by `ndsid replay` and the
// daemon; driven only by data timestamps, so live and replay take one code path.
#pragma once

#include <atomic>
#include <functional>
#include <future>
#include <map>
#include <memory>
#include <deque>
#include <optional>
#include <set>
#include <span>
#include <string>
#include <vector>

#include "ndsid/adequacy/adequacy.h"
#include "ndsid/adequacy/plausibility.h"
#include "ndsid/can/can_frame.h"
#include "ndsid/config/config.h"
#include "ndsid/dbc/database.h"
#include "ndsid/gate/gate.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/model/effect_library.h"
#include "ndsid/pipeline/model_choice.h"
#include "ndsid/stats/accumulator.h"
#include "ndsid/sync/role_extractor.h"
#include "ndsid/sync/signal_sync.h"
#include "ndsid/sync/time_base.h"

namespace ndsid::pipeline {

// Everything one identification produced, with the state of the data behind it.
struct Estimate {
  int64_t data_time_ns = 0;          // time of the newest sample when it was computed
  identify::IdentificationResult fit;
  stats::SteadyStateEstimate steady_state;
  adequacy::Report adequacy;
  adequacy::PlausibilityReport plausibility;  // checks of the window's data and of this estimate
  double gated_hours = 0;
  double window_hours = 0;
  size_t training_segments = 0;
  size_t validation_segments = 0;
  // Standstill evidence of the window (docs/two-outputs.md): its stops, and the gyro offset and
  // mean a_y they give (each once >= Identifier::kMinStops stops have it).
  size_t standstill_stops = 0;
  double standstill_seconds = 0;
  std::vector<identify::Identifier::StandstillPrior> standstill;
  // The refits with a kinematic scale disagreement attributed to each sensor (model_choice.h);
  // not judged (empty) when a_y and v r agree in scale.
  ModelChoice model_choice;
};

// The window split into training and held-out drives (every k-th drive validates, k from
// identification.validation_fraction), as an immutable snapshot another thread may fit.
struct WindowSnapshot {
  std::vector<std::shared_ptr<const stats::Segment>> keep_alive;
  identify::SegmentList training;
  identify::SegmentList validation;
  double gated_hours = 0;
  double window_hours = 0;
  int64_t data_time_ns = 0;
  stats::SteadyStateEstimate steady_state;
  stats::Coverage coverage;
  std::vector<gate::StandstillStop> standstill;  // the standstills of the window's drives (evidence)
  std::map<int64_t, adequacy::SpeedSums> wheel_speed;  // the window's drives' speed sums (plausibility)
  // The mean interval between the outputs' values on the bus [s] (0: unknown): a role slower
  // than the fit's sample rate is interpolated between its frames (ScaleFloorsForSlowRoles).
  double a_y_interval_s = 0, yaw_rate_interval_s = 0;

  std::vector<const stats::Segment*> AllSegments() const;  // training, then validation
};

// A periodic fit running on a worker thread beside the reading (the daemon, ndsid replay):
// Pipeline::StartFit() makes it, Accept(*job.snap, job.result.get(), &job.data_checks) records it.
struct FitJob {
  std::shared_ptr<const WindowSnapshot> snap;
  std::future<identify::IdentificationResult> result;  // get() waits for the fit and rethrows its error
  std::shared_ptr<std::atomic<double>> fit_s;          // the fit's own time [s], set by the worker when it ends
  adequacy::PlausibilityReport data_checks;            // CheckData(*snap), made on the starting thread before the fit
  // The model-choice refits (FitModelAlternatives), made by the worker after the fit: ready when
  // result is.
  std::shared_ptr<ModelChoice> choice;
};

class Pipeline {
 public:
  // Throws ConfigError when the configuration does not fit the DBC. config/db must outlive this.
  Pipeline(const config::Config& config, const dbc::Database& db);

  // The reading path: noexcept, O(frames), never waits on identification.
  void ProcessFrames(std::span<const can::CanFrame> frames, const std::vector<std::string>& bus_names) noexcept;
  void Finish();  // end of data: flush sync, close segments and drives

  // Identification is due every identification.period_s of data time once new gated data exist,
  // counted from the last accepted fit or, when given, from a fit still running on `pending`.
  bool IdentificationDue(const WindowSnapshot* pending = nullptr) const;
  WindowSnapshot Snapshot() const;
  // Fits a snapshot (may run on a worker thread; touches no pipeline state), incrementally on
  // top of `prior` (Prior()) when given, else over the whole window; with
  // identification.incremental the result carries its linearisation for the next update.
  // exact: every prior chunk relinearised at the solution (identify::IncrementalUpdate::exact).
  static identify::IdentificationResult Fit(const identify::Identifier& identifier, const WindowSnapshot& snap,
                                            const std::optional<std::vector<double>>& warm_start,
                                            std::shared_ptr<const identify::LinearizedWindow> prior = nullptr,
                                            bool exact = false);
  // Records a finished fit: updates adequacy, the last estimate and the incremental prior
  // (reading-thread side).
  // data_checks: CheckData(snap) computed beforehand (e.g. on the reading thread while the fit
  // ran); else computed here.
  // choice: the model-choice refits made with the fit (FitModelAlternatives); none: not judged.
  const Estimate& Accept(const WindowSnapshot& snap, identify::IdentificationResult fit,
                         const adequacy::PlausibilityReport* data_checks = nullptr, const ModelChoice* choice = nullptr);
  // The plausibility checks of a snapshot's data (kinematics, steering sign, wheel speeds): the
  // part of Accept's checks that does not depend on the fit. Touches no pipeline state.
  adequacy::PlausibilityReport CheckData(const WindowSnapshot& snap) const;
  // Starts the due fit on a worker thread: a snapshot, then Fit on copies of everything it touches
  // (snapshot, identifier, warm start, the exact-update schedule) and the shared, immutable prior,
  // after the snapshot's data checks are made on the calling thread (the worker reads their
  // kinematic gain for the model-choice refits). The job touches no pipeline
  // state; accept it before the next one starts (its result is the next one's warm start and prior).
  FitJob StartFit() const;
  // The same on a snapshot taken earlier (a replay that read on while the last fit ran): its fit
  // is the one it would have been then, as long as every fit before it has been accepted.
  FitJob StartFit(std::shared_ptr<const WindowSnapshot> snap) const;
  // Snapshot + Fit + Accept in one call (the CLI); final: the whole window's optimum (the final
  // fit; an exact update on the prior when there is one, else the whole window refitted).
  const Estimate& IdentifyNow(bool final = false);
  // The prior for the next periodic fit (docs/incremental.md): the last usable fit's
  // linearisation, or nothing when identification.incremental is off.
  std::shared_ptr<const identify::LinearizedWindow> Prior() const;
  // Whether the next periodic update is a scheduled exact one (every
  // identification.full_refit_every-th update relinearises every chunk of the prior).
  bool ExactDue() const;
  // model.watch at a fit of `gated_hours` (exact: a full-window or exact one): tested at those,
  // and where the gated time has doubled since the last test; else the last test's findings.
  WatchRequest Watch(bool exact, double gated_hours) const;
  const std::shared_ptr<const identify::LinearizedWindow>& linearized() const { return linearized_; }
  // Learned state: the prior restored from a persisted state (checked for the model and
  // scaling by the identifier, which ignores an incompatible one).
  void RestoreLinearized(std::shared_ptr<const identify::LinearizedWindow> w) { linearized_ = std::move(w); }

  const std::optional<Estimate>& last_estimate() const { return last_; }
  const std::vector<Estimate>& history() const { return history_; }
  const identify::Identifier& identifier() const { return identifier_; }
  // The configuration's effects (built-ins + model.formulas): every model built for this
  // configuration (compare, diagnose, the monitor) comes from it.
  const model::EffectLibrary& library() const { return library_; }
  const gate::Gate& gate() const { return gate_; }
  const sync::SignalSync& sync() const { return sync_; }
  // Clock faults handled before the sync stage (spikes dropped, steps back rebased).
  const sync::TimeBase& time_base() const { return time_base_; }
  const sync::RoleExtractor& extractor() const { return extractor_; }
  const stats::Accumulator& accumulator() const { return accumulator_; }
  const adequacy::Tracker& adequacy() const { return adequacy_; }
  adequacy::Tracker& mutable_adequacy() { return adequacy_; }
  int64_t data_time_ns() const { return data_time_ns_; }
  uint64_t frames() const { return frames_; }
  // Start of the next fit (full parameter vector, base then effects): the last valid fit,
  // else the steady-state estimate, else nothing (the configured initial values).
  std::optional<std::vector<double>> WarmStart() const;
  // The base six of WarmStart() (e.g. for the live model monitor).
  std::optional<model::Params<double>> WarmStartBase() const;

  // --- For the daemon (additive) ---
  // Called with every gated sample on the reading path (the monitor stream); must not throw.
  using SampleObserver = std::function<void(const gate::GatedSample&)>;
  void SetSampleObserver(SampleObserver observer) { observer_ = std::move(observer); }
  // Learned state persisted across restarts and reloads.
  stats::Accumulator& mutable_accumulator() { return accumulator_; }
  double last_fit_gated_hours() const { return last_fit_gated_hours_; }
  // Continues from a persisted state: the last estimate and the gated hours it was fitted at
  // (the next identification then waits for new gated data, as if no restart had happened).
  void RestoreLastEstimate(std::optional<Estimate> last, double last_fit_gated_hours) {
    last_ = std::move(last);
    last_fit_gated_hours_ = last_fit_gated_hours;
  }
  // The standstill stops of the window's drives (evidence on the gyro offset and the
  // accelerometer bias), persisted with the learned state so a restart keeps them; the newest
  // kMaxStops at most.
  static constexpr size_t kMaxStops = 100000;
  const std::deque<gate::StandstillStop>& stops() const { return stops_; }
  // Replaces the stops (after the accumulator is restored: stops of drives older than its
  // window are dropped, as while running).
  void RestoreStops(const std::vector<gate::StandstillStop>& stops);
  // The wheel-speed sums of the window's drives (the wheel_speed plausibility check).
  const std::map<int64_t, adequacy::SpeedSums>& wheel_speed() const { return wheel_speed_; }
  // Continues from the evidence of data other pipelines read (a fleet's per-log reductions
  // merged, pipeline/log_reduction.h): the drives' wheel-speed sums (those of drives older than
  // the window are dropped, as while reading) and the newest frame time.
  void RestoreEvidence(std::map<int64_t, adequacy::SpeedSums> wheel_speed, int64_t data_time_ns);

 private:
  void ConsumeSamples() noexcept;
  void DropStopsBeforeWindow();

  const config::Config& config_;
  sync::TimeBase time_base_;  // after config_: its new-base gap comes from the configuration
  std::vector<can::CanFrame> timed_;  // the frames TimeBase lets through (capacity kept)
  sync::SignalSync sync_;
  sync::RoleExtractor extractor_;
  gate::Gate gate_;
  stats::Accumulator accumulator_;
  model::EffectLibrary library_;
  identify::Identifier identifier_;
  adequacy::Tracker adequacy_;
  std::vector<sync::Sample> samples_;
  std::deque<gate::StandstillStop> stops_;
  std::map<int64_t, adequacy::SpeedSums> wheel_speed_;  // per drive of the window (plausibility; older ones are dropped)
  std::optional<Estimate> last_;
  // The last accepted fit's parameters whatever the checks said (the next fit's warm start): the
  // chain of fits does not depend on the validity verdicts, only what is published does.
  std::optional<std::vector<double>> last_fit_values_;
  std::shared_ptr<const identify::LinearizedWindow> linearized_;  // the incremental prior
  // What the last score test of model.watch found standing: carried to the incremental updates
  // until the next test (WatchRequest).
  std::vector<WatchFinding> watch_found_;
  double watch_tested_hours_ = 0;  // the gated hours of the last test
  std::vector<Estimate> history_;
  std::set<int64_t> implausible_drives_reported_;  // drives whose failed check was logged
  int64_t data_time_ns_ = 0;
  int64_t last_fit_data_ns_ = 0;
  double last_fit_gated_hours_ = -1;
  uint64_t frames_ = 0;
  SampleObserver observer_;
};

}  // namespace ndsid::pipeline
