#include "ndsid/pipeline/pipeline.h"

#include "fit_facts.h"

#include <spdlog/spdlog.h>

#include "ndsid/adequacy/prior_check.h"
#include "ndsid/common/error.h"
#include "ndsid/common/format.h"
#include "ndsid/stats/held_out.h"

#include <algorithm>
#include <cmath>
#include <chrono>
#include <map>
#include <set>

namespace ndsid::pipeline {
namespace {
// Below this the wheel speeds' quantisation and the speed signal's dead band dominate.
constexpr double kWheelCheckMinSpeed_mps = 2.0;

// The published sigma(EG) widened to cover the model choice's spread (adequacy::WidenedSigma).
void WidenSigma(double spread_deg_per_g, identify::IdentificationResult& fit) {
  const double widened = adequacy::WidenedSigma(fit.eg_se_deg_per_g, spread_deg_per_g);
  fit.eg_se_rad_per_mps2 = widened / model::EgToDegPerG(1.0);
  fit.eg_se_deg_per_g = widened;
}

// EG of model.priors (the adequacy tracker's reference before the first estimate,
// adequacy::PriorCredit): the prior on EG itself, else EG at the means of the priors on cv, ch
// and lv with m from a prior or fixed; else 0.
double PriorsEg(const config::Config& config) {
  for (const config::ParameterPrior& pr : config.identification.priors)
    if (pr.name == config::kEgPriorName) return pr.value / model::EgToDegPerG(1.0);
  model::Params<double> p{};
  const config::ParameterSpec& m = config.identification.params[model::kMass];
  double* slots[] = {&p.m, &p.cv, &p.ch, &p.lv};
  const char* names[] = {"m", "cv", "ch", "lv"};
  for (int k = 0; k < 4; ++k) {
    const auto it = std::find_if(config.identification.priors.begin(), config.identification.priors.end(),
                                 [&](const config::ParameterPrior& pr) { return pr.name == names[k]; });
    if (it != config.identification.priors.end()) {
      *slots[k] = it->value;
    } else if (k == 0 && m.fixed) {
      p.m = m.initial;
    } else {
      return 0;
    }
  }
  return model::SelfSteerGradient(p, config.vehicle.wheelbase_m);
}
}  // namespace

Pipeline::Pipeline(const config::Config& config, const dbc::Database& db)
    : config_(config),
      // A clock step back continues the drive after a gap the sync stage does not fill and the
      // gate does not take for a new drive: the segment is cut, the drive goes on.
      time_base_(static_cast<int64_t>(1e9 * std::clamp(2 * config.sync.max_fill_gap_s + 1.0, 2.0,
                                                         std::max(2.0, 0.5 * config.gate.drive_gap_s)))),
      sync_(config),
      extractor_(config, db),
      gate_(config.gate, 1.0 / config.sync.rate_hz),
      accumulator_(config, config.sync.rate_hz),
      library_(config.model_formulas),
      identifier_(config.identification, config.vehicle.wheelbase_m, model::ModelSpec::FromNames(config.model_effects, library_)),
      adequacy_(config.adequacy) {
  samples_.reserve(1024);
  timed_.reserve(sync::TimeBase::kConfirm + 2);
  CheckAlternatives(config.model_alternatives, config.model_effects, library_);
  CheckWatched(config.model_watch, library_);
  // model.priors must name a parameter of the base model, of a library effect or of a formula,
  // or EG itself.
  if (config.identification.priors.empty()) return;
  std::vector<std::string> known = {config::kEgPriorName};
  const model::ModelSpec base;
  for (int i = 0; i < base.num_params(); ++i) known.push_back(base.param_name(i));
  for (const auto& e : library_.names()) {
    const model::ModelSpec one = model::ModelSpec::FromNames({e}, library_);
    for (int i = model::kNumParams; i < one.num_params(); ++i) known.push_back(one.param_name(i));
  }
  for (const config::ParameterPrior& pr : config.identification.priors) {
    if (std::find(known.begin(), known.end(), pr.name) == known.end()) {
      throw ConfigError(pr.location + ": model.priors: '" + pr.name +
                        "' is not a parameter of the base model, a library effect or a formula, nor " +
                        config::kEgPriorName);
    }
  }
}

void Pipeline::ProcessFrames(std::span<const can::CanFrame> frames, const std::vector<std::string>& bus_names) noexcept {
  for (const can::CanFrame& raw : frames) {
    ++frames_;
    timed_.clear();
    const sync::TimeBaseCounters before = time_base_.counters();
    time_base_.Push(raw, timed_);  // at most kConfirm + 1 frames: within the reserved capacity
    const sync::TimeBaseCounters& now = time_base_.counters();
    if (now.spikes_dropped != before.spikes_dropped || now.steps_back != before.steps_back) {
      const uint64_t events = now.spikes_dropped + now.steps_back;
      if (events <= 10) {  // the first few, then the counters tell
        if (now.steps_back != before.steps_back)
          spdlog::warn("clock stepped back at t = {:.3f} s: a new time base (stamps shifted by {:.3f} s), the drive goes on",
                       1e-9 * static_cast<double>(raw.timestamp_ns), 1e-9 * static_cast<double>(now.shift_ns));
        else
          spdlog::warn("clock spike: {} frame(s) stamped more than 1 s off the time base dropped (near t = {:.3f} s)",
                       now.spikes_dropped - before.spikes_dropped, 1e-9 * static_cast<double>(raw.timestamp_ns));
      }
    }
    for (const can::CanFrame& f : timed_) {
      if (f.timestamp_ns > data_time_ns_) data_time_ns_ = f.timestamp_ns;
      sync_.Advance(f.timestamp_ns, samples_);
      extractor_.Process(f, bus_names, sync_);
    }
    if (samples_.size() >= 512) ConsumeSamples();
  }
  ConsumeSamples();
}

void Pipeline::ConsumeSamples() noexcept {
  for (const sync::Sample& s : samples_) {
    const gate::GatedSample g = gate_.Process(s);
    if (observer_) observer_(g);
    accumulator_.Add(g);
    const sync::Sample& x = g.sample;
    if (x.valid && x.has_wheel_speed && (x.speed_mps > kWheelCheckMinSpeed_mps || x.wheel_speed_mps > kWheelCheckMinSpeed_mps)) {
      try {
        wheel_speed_[accumulator_.DriveIdOf(g.drive_id)].Add(x.speed_mps, x.wheel_speed_mps, 1.0 / config_.sync.rate_hz, x.t_ns);
      } catch (...) {  // out of memory: the sample is not counted, nothing else
      }
    }
  }
  samples_.clear();
  if (!wheel_speed_.empty() && !accumulator_.window().empty()) {
    const int64_t first = accumulator_.window().front()->drive_id;
    while (!wheel_speed_.empty() && wheel_speed_.begin()->first < first) wheel_speed_.erase(wheel_speed_.begin());
  }
  std::vector<gate::StandstillStop> stops = gate_.TakeStops();
  if (stops.empty()) return;
  for (gate::StandstillStop& st : stops) {
    st.drive_id = accumulator_.DriveIdOf(st.drive_id);  // the window's numbering
    // After a restart the log is re-read from a little before the resume point (the warm-up):
    // a stop already kept (persisted) is not counted twice. Same drive, overlapping in time.
    const auto start = [](const gate::StandstillStop& s) { return static_cast<double>(s.t_start_ns); };
    const auto end = [](const gate::StandstillStop& s) { return static_cast<double>(s.t_start_ns) + s.seconds * 1e9; };
    // stops_ is ordered by drive: only the newest drive's stops need looking at.
    bool known = false;
    for (auto k = stops_.rbegin(); k != stops_.rend() && k->drive_id >= st.drive_id && !known; ++k)
      known = k->drive_id == st.drive_id && start(*k) < end(st) && start(st) < end(*k);
    if (known) continue;
    try {
      if (stops_.size() >= kMaxStops) stops_.pop_front();  // bounded like the gate's own list
      stops_.push_back(st);
    } catch (...) {  // out of memory: this stop is lost as evidence, nothing else
    }
  }
  DropStopsBeforeWindow();
}

void Pipeline::DropStopsBeforeWindow() {
  const auto& window = accumulator_.window();
  while (!stops_.empty() && !window.empty() && stops_.front().drive_id < window.front()->drive_id) stops_.pop_front();
}

void Pipeline::RestoreStops(const std::vector<gate::StandstillStop>& stops) {
  const size_t n = std::min(stops.size(), kMaxStops);
  stops_.assign(stops.end() - static_cast<std::ptrdiff_t>(n), stops.end());
  DropStopsBeforeWindow();
}

void Pipeline::RestoreEvidence(std::map<int64_t, adequacy::SpeedSums> wheel_speed, int64_t data_time_ns) {
  wheel_speed_ = std::move(wheel_speed);
  const auto& window = accumulator_.window();
  if (!window.empty()) {
    while (!wheel_speed_.empty() && wheel_speed_.begin()->first < window.front()->drive_id) wheel_speed_.erase(wheel_speed_.begin());
  }
  data_time_ns_ = data_time_ns;
}

void Pipeline::Finish() {
  time_base_.Finish();
  sync_.Flush(samples_);
  ConsumeSamples();
  gate_.Finish();
  ConsumeSamples();
  accumulator_.Finish();
}

bool Pipeline::IdentificationDue(const WindowSnapshot* pending) const {
  const double last_gated_h = pending ? pending->gated_hours : last_fit_gated_hours_;
  const int64_t last_data_ns = pending ? pending->data_time_ns : last_fit_data_ns_;
  if (accumulator_.gated_hours() <= last_gated_h) return false;
  if (accumulator_.window().empty()) return false;
  return static_cast<double>(data_time_ns_ - last_data_ns) * 1e-9 >= config_.identification.period_s;
}

WindowSnapshot Pipeline::Snapshot() const {
  WindowSnapshot snap;
  // Held-out drives (stats/held_out.h): every k-th drive (k = 1/validation_fraction); with fewer
  // than k drives in the window, the shortest one (training keeps most of the data), so that a
  // validation RMSE exists whenever 2 drives do.
  const std::set<int64_t> held_out = stats::HeldOutDrives(accumulator_.window(), config_.identification.validation_fraction);
  for (const auto& seg : accumulator_.window()) {
    snap.keep_alive.push_back(seg);
    (held_out.count(seg->drive_id) ? snap.validation : snap.training).push_back(seg.get());
  }
  if (snap.training.empty()) {  // a single drive: train on everything, no validation
    snap.training.swap(snap.validation);
  }
  snap.gated_hours = accumulator_.gated_hours();
  snap.window_hours = accumulator_.window_hours();
  snap.data_time_ns = data_time_ns_;
  const bool yaw = config_.role(config::Role::kYawRate) != nullptr;
  snap.steady_state = accumulator_.steady_state().Estimate(config_.vehicle.wheelbase_m, yaw);
  snap.coverage = accumulator_.coverage();
  std::set<int64_t> drives;
  for (const auto& seg : accumulator_.window()) drives.insert(seg->drive_id);
  for (const gate::StandstillStop& st : stops_)
    if (drives.count(st.drive_id)) snap.standstill.push_back(st);
  for (const int64_t d : drives) {
    const auto it = wheel_speed_.find(d);
    if (it != wheel_speed_.end()) snap.wheel_speed.emplace(*it);
  }
  snap.a_y_interval_s = sync_.MeanInterval_s(config::Role::kLateralAcceleration);
  snap.yaw_rate_interval_s = sync_.MeanInterval_s(config::Role::kYawRate);
  return snap;
}

std::optional<std::vector<double>> Pipeline::WarmStart() const {
  if (last_fit_values_) return last_fit_values_;
  if (last_ && last_->fit.valid) return last_->fit.ValuesFor(identifier_.spec());  // restored: maybe another model
  const bool yaw = config_.role(config::Role::kYawRate) != nullptr;
  const auto ss = accumulator_.steady_state().Estimate(config_.vehicle.wheelbase_m, yaw);
  if (ss.valid) return identifier_.FullVector(identifier_.WarmStart(ss.steer_ratio, ss.eg_rad_per_mps2));
  return std::nullopt;
}

std::optional<model::Params<double>> Pipeline::WarmStartBase() const {
  const auto full = WarmStart();
  if (!full) return std::nullopt;
  return model::Params<double>::FromArray(full->data());
}

identify::IdentificationResult Pipeline::Fit(const identify::Identifier& identifier, const WindowSnapshot& snap,
                                             const std::optional<std::vector<double>>& warm_start,
                                             std::shared_ptr<const identify::LinearizedWindow> prior, bool exact) {
  identify::Identifier id = identifier;  // the snapshot's standstills, on this thread's copy
  id.set_standstill(snap.standstill);
  const config::IdentificationConfig& c = identifier.config();
  if (!c.incremental) return id.Identify(snap.training, snap.validation, warm_start);
  return id.Identify(snap.training, snap.validation, warm_start,
                     identify::IncrementalUpdate{std::move(prior), c.relinearize_sigma, true, exact});
}

std::shared_ptr<const identify::LinearizedWindow> Pipeline::Prior() const {
  const config::IdentificationConfig& c = config_.identification;
  if (!c.incremental || !linearized_) return nullptr;
  return linearized_;
}

bool Pipeline::ExactDue() const {
  const config::IdentificationConfig& c = config_.identification;
  return c.incremental && linearized_ && c.full_refit_every > 0 && linearized_->updates_since_full + 1 >= c.full_refit_every;
}

WatchRequest Pipeline::Watch(bool exact, double gated_hours) const {
  const config::IdentificationConfig& c = config_.identification;
  const bool test = !c.incremental || !linearized_ || exact || gated_hours >= 2 * watch_tested_hours_;
  return WatchRequest{.effects = config_.model_watch, .test = test, .found = watch_found_};
}

FitJob Pipeline::StartFit() const { return StartFit(std::make_shared<const WindowSnapshot>(Snapshot())); }

FitJob Pipeline::StartFit(std::shared_ptr<const WindowSnapshot> snap) const {
  FitJob job;
  job.snap = std::move(snap);
  job.fit_s = std::make_shared<std::atomic<double>>(0.0);
  job.choice = std::make_shared<ModelChoice>();
  job.data_checks = CheckData(*job.snap);  // on this thread; the worker reads the kinematic gain
  job.result = std::async(std::launch::async, [snap = job.snap, identifier = identifier_, warm = WarmStart(), prior = Prior(),
                                               exact = ExactDue(), fit_s = job.fit_s, checks = job.data_checks, choice = job.choice,
                                               track = config_.vehicle.track_rear_m, alternatives = config_.model_alternatives,
                                               watch = Watch(ExactDue(), job.snap->gated_hours)] {
    const auto t0 = std::chrono::steady_clock::now();
    identify::IdentificationResult r = Fit(identifier, *snap, warm, prior, exact);
    *choice = FitModelAlternatives(identifier, *snap, r, checks, track, alternatives, watch);
    fit_s->store(std::chrono::duration<double>(std::chrono::steady_clock::now() - t0).count());
    return r;
  });
  return job;
}

std::vector<const stats::Segment*> WindowSnapshot::AllSegments() const {
  std::vector<const stats::Segment*> all(training.begin(), training.end());
  all.insert(all.end(), validation.begin(), validation.end());
  return all;
}

adequacy::PlausibilityReport Pipeline::CheckData(const WindowSnapshot& snap) const {
  adequacy::PlausibilityReport r = adequacy::CheckData(snap.AllSegments(), config_.plausibility);
  adequacy::CheckWheelSpeed(snap.wheel_speed, config_.plausibility, r);  // as at the snapshot
  return r;
}

namespace {

// How far the fit ended from model.priors (adequacy/prior_check.h): a note, and the check
// `prior`; a fit that contradicts its priors is a compromise between them and the data, so it is
// not valid (refit without them). Returns whether it contradicts them.
bool CheckPriors(const std::vector<config::ParameterPrior>& priors, Estimate& e) {
  if (priors.empty()) return false;
  std::vector<adequacy::FittedParameter> fitted;
  for (const auto& p : e.fit.params) fitted.push_back({p.name, p.value, p.fixed});
  for (const auto& p : e.fit.effect_params) fitted.push_back({p.name, p.value, p.fixed});
  fitted.push_back({config::kEgPriorName, e.fit.eg_deg_per_g, false});
  const adequacy::PriorDistance d = adequacy::DistanceFromPriors(fitted, priors);
  if (d.z.empty()) return false;
  e.fit.identifiability.notes.push_back(d.Note());
  adequacy::Check c{.name = "prior", .value = d.distance, .message = d.Note()};
  c.verdict = d.contradicts ? adequacy::Verdict::kFailed : adequacy::Verdict::kPassed;
  e.plausibility.checks.push_back(c);
  if (d.contradicts) {
    e.fit.reason = e.fit.valid ? e.plausibility.Reason() : e.fit.reason + "; " + c.message;
    e.fit.valid = false;
  }
  return d.contradicts;
}

}  // namespace

const Estimate& Pipeline::Accept(const WindowSnapshot& snap, identify::IdentificationResult fit,
                                 const adequacy::PlausibilityReport* data_checks, const ModelChoice* choice) {
  last_fit_data_ns_ = snap.data_time_ns;
  last_fit_gated_hours_ = snap.gated_hours;
  if (choice && choice->watch_tested) {
    watch_found_ = WatchFound(*choice, fit.eg_deg_per_g);
    watch_tested_hours_ = snap.gated_hours;
  }
  Estimate e;
  e.data_time_ns = snap.data_time_ns;
  e.steady_state = snap.steady_state;
  e.gated_hours = snap.gated_hours;
  e.window_hours = snap.window_hours;
  e.training_segments = snap.training.size();
  e.validation_segments = snap.validation.size();
  e.standstill_stops = snap.standstill.size();
  for (const auto& st : snap.standstill) e.standstill_seconds += st.seconds;
  e.standstill = identify::Identifier::StandstillPriors(snap.standstill, {});
  // The next update's prior: this fit's linearisation, or none after a failed fit (the next one
  // then refits the whole window). Not kept in the estimate and its history.
  linearized_ = std::move(fit.linearized);
  fit.linearized.reset();
  e.fit = std::move(fit);
  // The rear wheels ruled the fit out and an attribution stands (pipeline/model_choice.h): that
  // refit is published; the next update's prior stays the fit's own linearisation.
  if (choice && !choice->published.empty()) {
    for (const ModelAlternative& a : choice->alternatives)
      if (a.name == choice->published && a.result) e.fit = *a.result;
  }
  ScaleFloorsForSlowRoles(snap, config_.identification.rate_hz, e.fit);
  if (e.fit.valid) last_fit_values_ = e.fit.ValuesFor(identifier_.spec());  // a usable fit, before the checks
  // Plausibility (docs/monitoring.md): a fit of data that break the kinematics, or an EG that is
  // unphysical or undetermined, is published as not valid, with the checks' words as reason.
  e.plausibility = data_checks ? *data_checks : CheckData(snap);
  if (choice) e.model_choice = *choice;
  if (e.fit.valid) {
    const adequacy::FitFacts fit_facts = FitFactsOf(e.fit, snap, &e.model_choice);
    if (fit_facts.model_choice) WidenSigma(adequacy::ModelChoiceSpread(e.fit.eg_deg_per_g, *fit_facts.model_choice), e.fit);
    adequacy::EstimateFacts facts;
    facts.steer_ratio = snap.steady_state.valid ? snap.steady_state.steer_ratio : 0;
    facts.eg_deg_per_g = e.fit.eg_deg_per_g;
    facts.eg_se_deg_per_g = e.fit.eg_se_deg_per_g;
    for (const auto& p : e.fit.params) {
      if (p.fixed) continue;
      ++facts.free_params;
      facts.free_params_at_bound += p.at_bound ? 1 : 0;
    }
    adequacy::CheckEstimate(facts, config_.plausibility, e.plausibility);
    adequacy::CheckFit(fit_facts, config_.plausibility, e.plausibility);
    for (const auto& d : e.plausibility.drives) {  // each failing drive once
      for (const auto& c : d.checks) {
        if (c.verdict == adequacy::Verdict::kFailed && implausible_drives_reported_.insert(d.drive_id).second) {
          spdlog::warn("plausibility: drive {} (from t = {:.3f} s): {}", d.drive_id, 1e-9 * static_cast<double>(d.t0_ns), c.message);
        }
      }
    }
    if (!e.plausibility.passed()) {
      e.fit.valid = false;
      e.fit.reason = e.plausibility.Reason();
    }
  }
  // What model.priors are worth to the adequacy tracker: none without them, none when the fit
  // contradicts them.
  adequacy::PriorCredit credit = adequacy::CreditOf(e.fit.eg_prior_info_share, snap.window_hours, PriorsEg(config_));
  if (CheckPriors(config_.identification.priors, e)) credit = {};
  if (credit.hours > 0) {
    e.fit.identifiability.notes.push_back(
        Fmt("model.priors hold %.0f %% of EG's information, as much as %.2f h more of this driving (the adequacy "
            "tracker counts them so; their EG %.4f deg/g)",
            100 * e.fit.eg_prior_info_share, credit.hours, model::EgToDegPerG(credit.eg)));
  }
  if (e.fit.valid) {
    e.adequacy = adequacy_.Update(snap.gated_hours, e.fit.eg_rad_per_mps2, e.fit.eg_se_rad_per_mps2, snap.coverage, credit);
    last_ = e;
  } else {
    // Keep the last good estimate; report this one as not valid with its reason.
    e.adequacy = adequacy_.last();
    if (e.adequacy.explanation.empty()) {
      e.adequacy.gated_hours = snap.gated_hours;
      e.adequacy.explanation = "no valid estimate yet: adequacy is judged on valid estimates only";
    }
    spdlog::warn("identification not valid: {}", e.fit.reason);
    if (!last_) last_ = e;
  }
  history_.push_back(e);
  return history_.back();
}

const Estimate& Pipeline::IdentifyNow(bool final) {
  const auto t0 = std::chrono::steady_clock::now();
  const WindowSnapshot snap = Snapshot();
  const auto t1 = std::chrono::steady_clock::now();
  const adequacy::PlausibilityReport checks = CheckData(snap);
  identify::IdentificationResult fit = Fit(identifier_, snap, WarmStart(), Prior(), final || ExactDue());
  const ModelChoice choice = FitModelAlternatives(identifier_, snap, fit, checks, config_.vehicle.track_rear_m, config_.model_alternatives,
                                                   Watch(final || ExactDue(), snap.gated_hours));
  const auto t2 = std::chrono::steady_clock::now();
  const Estimate& e = Accept(snap, std::move(fit), &checks, &choice);
  const auto t3 = std::chrono::steady_clock::now();
  using S = std::chrono::duration<double>;
  spdlog::debug("identification times: snapshot {:.3f} s, fit {:.3f} s, checks {:.3f} s", S(t1 - t0).count(), S(t2 - t1).count(),
                S(t3 - t2).count());
  return e;
}

}  // namespace ndsid::pipeline
