#include "window_fit.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <map>

#include "fit_statistics.h"
#include "held_out.h"
#include "residual_sums.h"

namespace ndsid::identify {
namespace {

// Rounds of in-place relinearisation after the first incremental solve; an update still unsettled
// is fitted as the whole window.
constexpr int kRelinearizeRounds = 4;
// A first EG check that finds the quadratics' error moving EG by more than this many of its
// standard deviations: the rounds (undamped Gauss-Newton steps on the whole window) seldom settle
// from so far, and the update is fitted as the whole window at once.
constexpr double kEgCheckHopeless = 1.0;
// An incremental update keeps its new chunks' last residuals and Jacobians for the statistics at
// the optimum while they take at most this much memory (64 MiB hold about 150 one-minute chunks at
// 50 Hz with both outputs and 8 parameters).
constexpr size_t kKeepLastBytes = size_t{64} << 20;

// Why an update was fitted as the whole window instead (IdentificationResult::update).
constexpr const char* kNewDataOutnumberPrior =
    "incremental: more chunks to simulate than the prior holds, so fitted as the whole window";
constexpr const char* kNotRelinearized =
    "incremental: a prior chunk could not be relinearised (non-finite residuals), so fitted as the whole window";
constexpr const char* kFarOff = "incremental: the EG check found the prior's quadratics far off, so fitted as the whole window";
constexpr const char* kUnsettled =
    "incremental: the estimate still left the prior's linearisation points after the relinearisation rounds, "
    "so fitted as the whole window";

// The distance rule at an update's first solution [prior sigma]: relinearize_sigma, an exact
// update's at most kExactSigma.
double SigmaRule(const IncrementalUpdate* update) {
  if (!update) return 0.0;
  return update->exact ? std::min(update->relinearize_sigma, kExactSigma) : update->relinearize_sigma;
}

}  // namespace

WindowFit::WindowFit(const Identifier& identifier, const SegmentList& training, const SegmentList& validation,
                     const std::optional<std::vector<double>>& warm_start, const IncrementalUpdate* update)
    : identifier_(identifier),
      training_(training),
      validation_(validation),
      warm_start_(warm_start),
      update_(update),
      settings_{identifier.config(), identifier.spec(), identifier.wheelbase_m(), identifier.drive_overrides()},
      box_(ParameterBox::Make(identifier.config(), identifier.spec())),
      keep_(update && update->keep),
      sigma_rule_(SigmaRule(update)),
      start_(std::chrono::steady_clock::now()),
      theta_(box_.Start(warm_start)),
      fit_(settings_, box_.scale, theta_.data()),
      lap_(std::chrono::steady_clock::now()) {
  result_.model = identifier.spec().Describe();
}

IdentificationResult WindowFit::Run() {
  if (!CutWindow()) return result_;
  if (PriorOutputsDiffer()) return WholeWindow(nullptr);
  if (NewDataOutnumberPrior()) return WholeWindow(kNewDataOutnumberPrior);
  if (!SetUpCosts() || !AddPriors()) return result_;
  Solve();
  if (!SettleOnPrior() || !SolverSucceeded() || !ComputeStatistics()) return result_;
  EstimateHeldOut();
  Finish();
  return result_;
}

bool WindowFit::CutWindow() {
  const config::IdentificationConfig& config = settings_.config;
  // Incremental update (docs/incremental.md): the training segments the prior holds enter the
  // fit as their chunks' quadratics; the others are simulated.
  SegmentList simulated = training_;
  if (update_ && update_->prior && settings_.drive_overrides.empty() &&
      update_->prior->Compatible(result_.model, box_.scale, config.chunk_s, config.burn_in_s)) {
    prior_.emplace(settings_, *update_->prior, theta_);  // theta: the anchor along the prior's weak directions
    simulated = prior_->Split(training_);
  }
  fit_.Cut(simulated);
  if (fit_.chunks.empty() && (!prior_ || prior_->segments().empty())) {
    result_.reason = "no gated segment long enough for the dynamic fit";
    return false;
  }
  // Outputs: a_y alone (weight 1: the classical fit), or a_y and the yaw rate, each divided by
  // the square root of its noise level sigma^2 tau, first at the start values, then (Solve) at
  // the solution, refitting once when the ratio of the two moved by more than 1.5x.
  // With a prior, its weights hold (the outputs must be the same as when it was built).
  chunks_with_yaw_ = fit_.ChunksWithYawRate();
  // A prior segment counts by its data, not by its quadratics: those of a prior built for a_y
  // alone hold no yaw-rate residuals even where the data have a yaw rate.
  if (prior_) chunks_with_yaw_ += prior_->ChunksWithYawRate();
  two_outputs_ = config.yaw_rate_output && chunks_with_yaw_ > 0;
  return true;
}

bool WindowFit::PriorOutputsDiffer() const {
  return prior_ && two_outputs_ != (prior_->window().weight_yaw_rate > 0);
}

bool WindowFit::NewDataOutnumberPrior() const {
  return prior_ && two_outputs_ && fit_.chunks.size() >= prior_->NumChunks();
}

bool WindowFit::SetUpCosts() {
  OutputWeights& weights = *fit_.weights;
  weights.yaw_rate = two_outputs_ ? 1.0 : 0.0;
  if (prior_) weights = {prior_->window().weight_a_y, prior_->window().weight_yaw_rate};
  fit_.AddCosts();
  if (!prior_) {
    fit_.EstimateWeights(two_outputs_);
    return true;
  }
  // An update on a prior keeps each new chunk's last evaluation with its Jacobian for the
  // statistics at the optimum (chunk_cost.h), up to kKeepLastBytes of them.
  fit_.KeepLastWithin(kKeepLastBytes);
  prior_->ReweightToWindow(fit_, two_outputs_);
  // Stale prior segments (their linearisation points left behind by the estimate) are
  // relinearised in place: each chunk simulated once with its Jacobian at theta, its quadratic
  // replaced by the one there (a copy of the prior holds them). The fit then goes on with the
  // quadratics, a Gauss-Newton step on those chunks; where that step leaves them again, the
  // checks after the solve relinearise them at the new point. At a solution where no chunk is
  // stale the scores of all chunks sum to zero as in the whole-window fit.
  // At the start, the distance rule of an ordinary update even for an exact one: the start (the
  // last estimate) is not the solution, and the exact rule applies there (after the solve), so
  // relinearising every chunk here too would only be done again.
  if (!Relinearize(prior_->StaleSegments(theta_, update_->relinearize_sigma, prior_->TakeMoments())))
    return EndWholeWindow(kNotRelinearized);
  prior_->SetQuadratic();
  fit_.problem.AddResidualBlock(&prior_->quadratic(), nullptr, theta_.data());
  return true;
}

bool WindowFit::AddPriors() {
  if (box_.free.empty()) {
    result_.reason = "every parameter is fixed";
    return false;
  }
  box_.Constrain(fit_.problem, theta_.data());
  priors_.Build(settings_, box_, training_, identifier_.standstill());
  priors_.AddTo(fit_.problem, theta_.data());
  ReweightPriors();
  return true;
}

void WindowFit::Solve() {
  solver_.emplace(settings_.config, box_, theta_.data(), prior_.has_value());
  // Coarse start of a large fit without a prior: the solver first runs on every k-th chunk, about
  // coarse_chunks of them, then finishes on the whole window from there.
  if (!prior_ && solver_->WantsCoarseStart(fit_.costs.size())) {
    const CoarseStart coarse = solver_->SolveCoarse(fit_, priors_, [this]() { return ReweightOutputs(); });
    result_.coarse_iterations = coarse.iterations;
    result_.coarse_start_used = coarse.used;
  }
  Lap(0);
  result_.iterations = solver_->Solve(fit_.problem);
  if (two_outputs_ && !prior_ && solver_->usable() && ReweightOutputs()) {
    // The outputs' noise levels at the solution differ from those at the start: refit once.
    result_.iterations += solver_->Solve(fit_.problem);
    spdlog::debug("two outputs: refitted with weights a_y {:.4g}, yaw rate {:.4g}", fit_.weights->a_y, fit_.weights->yaw_rate);
  }
  if (!priors_.empty() && solver_->usable()) {
    // The priors' weight was the noise level at the start; refit once if the fit moved it much.
    const double level = NoiseLevel();
    if (PriorsWeightMoved(level)) {
      priors_.SetWeight(level);
      result_.iterations += solver_->Solve(fit_.problem);
    }
  }
}

bool WindowFit::PriorsWeightMoved(double level) const {
  return level > 0 && (level > 2 * priors_.weight() || level < 0.5 * priors_.weight());
}

// If the solution left some prior segments' linearisation points, they are relinearised there
// and the update solved again (at most kRelinearizeRounds rounds). The quadratics are also checked
// where it matters, on EG (eg_check.h): where they move EG or its variance too much, every prior
// segment is relinearised (and the update solved again). An exact update's distance rule applies
// at its first solution; after that the ordinary rule and the exact update's tighter EG check.
bool WindowFit::SettleOnPrior() {
  bool settled = !prior_;
  Lap(1);
  for (int round = 0; prior_ && solver_->usable(); ++round) {
    const IncrementalPrior::Moments pm = prior_->TakeMoments();
    std::vector<size_t> stale = prior_->StaleSegments(theta_, round == 0 ? sigma_rule_ : update_->relinearize_sigma, pm);
    const bool checked = stale.empty();
    const EgCheckResult check =
        checked && !CheckedBefore(pm) ? CheckEg(settings_, box_, *prior_, pm, theta_, fit_.weights, update_->exact) : EgCheckResult{};
    if (!check.eg || !check.sigma) {
      for (size_t i = 0; i < prior_->segments().size(); ++i) stale.push_back(i);
    }
    if (stale.empty()) {
      settled = true;
      break;
    }
    if (checked && round == 0 && FarOff(check)) return EndWholeWindow(kFarOff);
    if (checked && OnlyVarianceOff(check)) {
      if (!Relinearize(stale)) return EndWholeWindow(kNotRelinearized);
      settled = true;
      break;
    }
    if (round == kRelinearizeRounds) break;
    if (!Relinearize(stale)) return EndWholeWindow(kNotRelinearized);
    prior_->SetQuadratic();
    Lap(2);
    result_.iterations += solver_->Solve(fit_.problem);
    Lap(1);
  }
  Lap(2);
  if (!settled && solver_->usable()) return EndWholeWindow(kUnsettled);
  return true;
}

bool WindowFit::CheckedBefore(const IncrementalPrior::Moments& pm) const {
  return !update_->exact && prior_->CheckedNear(theta_, pm);
}

bool WindowFit::FarOff(const EgCheckResult& check) const { return !(check.shift <= kEgCheckHopeless); }

// The step the fresh quadratics imply moves EG by less than kEgCheck of its standard deviation
// (the check passed on EG). An exact update whose check does not hold the quadratics' error to its
// tighter limits relinearises every chunk again and solves again: it ends on a solve.
bool WindowFit::OnlyVarianceOff(const EgCheckResult& check) const { return check.eg && !update_->exact; }

bool WindowFit::SolverSucceeded() {
  const ceres::Solver::Summary& summary = solver_->summary();
  result_.termination = ceres::TerminationTypeToString(summary.termination_type);
  if (summary.IsSolutionUsable()) return true;
  result_.reason = "solver failed: " + summary.message;
  return false;
}

bool WindowFit::ComputeStatistics() {
  sums_ = SumAtOptimum(fit_, prior_ ? &*prior_ : nullptr, theta_, training_, keep_, two_outputs_, result_);
  if (!SetTrainingFit(sums_, *fit_.weights, prior_.has_value(), two_outputs_, settings_.config.threads, result_)) return false;
  FitStatistics statistics(settings_, box_, theta_, priors_, sums_, result_);
  statistics.Covariance(prior_.has_value());
  statistics.Estimates();
  statistics.BoundShift();
  statistics.EgCorrelations();
  statistics.Halves();
  // Both counts over the whole window: the prior's held chunks and the chunks fitted here.
  statistics.Identifiability(two_outputs_, chunks_with_yaw_, fit_.chunks.size() + (prior_ ? prior_->NumChunks() : 0));
  Lap(3);
  return true;
}

void WindowFit::EstimateHeldOut() {
  if (validation_.empty()) return;
  const bool from_quadratics = keep_ && HeldOutFromQuadratics(settings_, box_, validation_, theta_, prior_ ? &*prior_ : nullptr,
                                                              sigma_rule_, two_outputs_, held_lin_, result_);
  if (!from_quadratics) HeldOutBySimulation(settings_, validation_, two_outputs_, result_);
}

void WindowFit::Finish() {
  IdentificationResult& r = result_;
  Lap(4);
  r.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - start_).count();
  spdlog::debug("fit times: setup {:.3f} s, solve {:.3f} s ({} iterations), checks and relinearisation {:.3f} s, statistics at "
                "the optimum {:.3f} s, held-out RMSE {:.3f} s; {} chunks simulated, {} relinearised", phase_s_[0], phase_s_[1],
                r.iterations, phase_s_[2], phase_s_[3], phase_s_[4], r.chunks_simulated, r.chunks_relinearized);
  r.valid = std::isfinite(r.eg_rad_per_mps2) && std::isfinite(r.eg_se_rad_per_mps2);
  if (!r.valid) r.reason = "non-finite EG or standard error";
  if (prior_) {
    char how[200];
    std::snprintf(how, sizeof how, "incremental%s: %zu chunks simulated, %zu from the prior (%zu relinearisations)",
                  update_->exact ? " (exact)" : "", r.chunks_simulated, r.chunks_from_prior, r.chunks_relinearized);
    r.update = how;
  }
  if (keep_ && r.valid) r.linearized = NextPrior();
}

std::shared_ptr<const LinearizedWindow> WindowFit::NextPrior() {
  const config::IdentificationConfig& config = settings_.config;
  auto lw = std::make_shared<LinearizedWindow>();
  lw->model = result_.model;
  lw->scale = box_.scale;
  lw->weight_a_y = fit_.weights->a_y;
  lw->weight_yaw_rate = fit_.weights->yaw_rate;
  lw->chunk_s = config.chunk_s;
  lw->burn_in_s = config.burn_in_s;
  lw->updates_since_full =
      prior_ && result_.chunks_from_prior > 0 && !update_->exact ? prior_->window().updates_since_full + 1 : 0;
  lw->checked_at = theta_;  // settled: checked there, exact there, or every chunk fresh
  std::map<const stats::Segment*, const LinearizedSegment*> kept;
  if (prior_)
    for (const IncrementalPrior::Segment& ps : prior_->segments()) kept[ps.seg] = ps.lin;
  std::map<const stats::Segment*, std::vector<size_t>> fresh;
  for (size_t ci = 0; ci < fit_.chunks.size(); ++ci) fresh[fit_.chunk_segment[ci]].push_back(ci);
  for (const stats::Segment* seg : training_) {
    if (!seg) continue;
    LinearizedSegment ls;
    ls.drive_id = seg->drive_id;
    ls.t0_ns = seg->t0_ns;
    ls.samples = seg->samples.size();
    if (const auto k = kept.find(seg); k != kept.end()) {
      ls.chunks = k->second->chunks;
    } else if (const auto f = fresh.find(seg); f != fresh.end()) {
      for (size_t ci : f->second) ls.chunks.push_back(std::move(sums_.simulated_lin[ci]));
    }
    if (!ls.chunks.empty()) lw->segments.push_back(std::move(ls));
  }
  for (LinearizedSegment& ls : held_lin_)
    if (!ls.chunks.empty()) lw->held_out.push_back(std::move(ls));
  return lw;
}

IdentificationResult WindowFit::WholeWindow(const char* note) const {
  IncrementalUpdate whole = *update_;
  whole.prior = nullptr;
  IdentificationResult w = WindowFit(identifier_, training_, validation_, warm_start_, &whole).Run();
  if (note) w.update = note;
  return w;
}

bool WindowFit::EndWholeWindow(const char* note) {
  result_ = WholeWindow(note);
  return false;
}

double WindowFit::NoiseLevel() const {
  if (!prior_) return fit_.NoiseLevel();
  std::vector<std::vector<double>> a, rr;
  fit_.EvaluateSeries(a, rr);
  std::vector<double> acf(kAcfMaxLag + 1, 0.0);
  double n = AddSeriesSums(a, acf);  // in this order: the sums add up in it
  n += AddSeriesSums(rr, acf);
  n += prior_->PoolSums(acf);
  return LevelOfSums(acf, n);
}

void WindowFit::ReweightPriors() {
  if (!priors_.empty()) priors_.SetWeight(NoiseLevel());
}

bool WindowFit::ReweightOutputs() {
  if (!fit_.EstimateWeights(two_outputs_)) return false;
  ReweightPriors();
  return true;
}

bool WindowFit::Relinearize(const std::vector<size_t>& stale) {
  return prior_->Relinearize(stale, theta_, box_.scale, fit_.weights, two_outputs_, result_.chunks_relinearized);
}

void WindowFit::Lap(int k) {
  const auto now = std::chrono::steady_clock::now();
  phase_s_[k] += std::chrono::duration<double>(now - lap_).count();
  lap_ = now;
}

}  // namespace ndsid::identify
