#include "ndsid/identify/identifier.h"
#include "ndsid/stats/speed_scale.h"
#include "ndsid/model/effect_library.h"

#include <ceres/ceres.h>
#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <limits>
#include <memory>
#include <optional>
#include <sstream>

#include "chunk_cost.h"
#include "eg_check.h"
#include "evidence_priors.h"
#include "fit_problem.h"
#include "fit_statistics.h"
#include "held_out.h"
#include "incremental_prior.h"
#include "optimum_sums.h"
#include "parallel.h"
#include "quadratic_prior.h"
#include "residual_sums.h"
#include "window_solve.h"

namespace ndsid::identify {

std::string CeresVersion() { return CERES_VERSION_STRING; }
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

}  // namespace

model::Params<double> IdentificationResult::AsParams() const {
  double p[6];
  for (int i = 0; i < 6; ++i) p[i] = params[i].value;
  return model::Params<double>::FromArray(p);
}

std::vector<double> IdentificationResult::ValuesFor(const model::ModelSpec& spec) const {
  std::vector<double> v;
  for (const auto& p : params) v.push_back(p.value);
  for (int i = model::kNumParams; i < spec.num_params(); ++i) {
    const std::string name = spec.param_name(i);
    const auto it = std::find_if(effect_params.begin(), effect_params.end(), [&](const ParameterEstimate& p) { return p.name == name; });
    v.push_back(it != effect_params.end() ? it->value : spec.effect_param(i)->neutral);
  }
  return v;
}

size_t IdentificationResult::NumEstimated() const {
  size_t n = 0;
  for (const auto& p : params) n += p.fixed ? 0 : 1;
  for (const auto& p : effect_params) n += p.fixed ? 0 : 1;
  for (const DriveValue& v : drive_values) n += v.reference || v.validation ? 0 : 1;
  return n;
}

std::vector<double> IdentificationResult::AllValues() const {
  std::vector<double> v;
  for (const auto& p : params) v.push_back(p.value);
  for (const auto& p : effect_params) v.push_back(p.value);
  return v;
}

Identifier::Identifier(const config::IdentificationConfig& config, double wheelbase_m, model::ModelSpec spec)
    : config_(config), wheelbase_m_(wheelbase_m), spec_(std::move(spec)) {}

model::Params<double> Identifier::WarmStart(double steer_ratio, double eg) const {
  double p[6];
  for (int i = 0; i < 6; ++i) p[i] = config_.params[i].initial;
  auto clamp = [&](int i, double v) { return std::clamp(v, config_.params[i].lower, config_.params[i].upper); };
  if (std::isfinite(steer_ratio) && steer_ratio > 0) p[model::kSteerRatio] = clamp(model::kSteerRatio, steer_ratio);
  if (std::isfinite(eg)) {
    // EG = m/l (lh/cv - lv/ch)  =>  cv = lh / (EG l/m + lv/ch)
    const double l = wheelbase_m_, m = p[model::kMass], lv = p[model::kCgToFront], lh = l - lv;
    const double denom = eg * l / m + lv / p[model::kStiffRear];
    if (denom > 0) p[model::kStiffFront] = clamp(model::kStiffFront, lh / denom);
  }
  return model::Params<double>::FromArray(p);
}

std::vector<double> Identifier::FullVector(const model::Params<double>& p) const {
  std::vector<double> v = {p.m, p.Jz, p.cv, p.ch, p.lv, p.is};
  for (int i = model::kNumParams; i < spec_.num_params(); ++i) v.push_back(spec_.effect_param(i)->initial);
  return v;
}

double Identifier::Rmse(const model::Params<double>& p, const SegmentList& segments, size_t* count) const {
  return Rmse(FullVector(p), segments, count);
}

double Identifier::Rmse(const std::vector<double>& params, const SegmentList& segments, size_t* count) const {
  const ErrorSums s = SimulatedErrorSums(spec_, wheelbase_m_, MakeChunks(segments, config_.chunk_s, config_.burn_in_s, drive_overrides_),
                                         params, config_.burn_in_s, false, config_.threads);
  if (count) *count = s.na;
  return RootMean(s.a, s.na);
}

double Identifier::RmseYawRate(const std::vector<double>& params, const SegmentList& segments, size_t* count) const {
  const ErrorSums s = SimulatedErrorSums(spec_, wheelbase_m_, MakeChunks(segments, config_.chunk_s, config_.burn_in_s, drive_overrides_),
                                         params, config_.burn_in_s, true, config_.threads);
  if (count) *count = s.nr;
  return RootMean(s.r, s.nr);
}

IdentificationResult Identifier::Identify(const SegmentList& training, const SegmentList& validation,
                                          const std::optional<model::Params<double>>& warm_start) const {
  return Identify(training, validation,
                  warm_start ? std::optional<std::vector<double>>(FullVector(*warm_start)) : std::nullopt);
}

IdentificationResult Identifier::Identify(const SegmentList& training, const SegmentList& validation,
                                          const std::optional<std::vector<double>>& warm_start) const {
  return spec_.per_drive_params().empty() ? IdentifyAtDriveValues(training, validation, warm_start)
                                         : IdentifyPerDrive(training, validation, warm_start);
}

IdentificationResult Identifier::Identify(const SegmentList& training, const SegmentList& validation,
                                          const std::optional<std::vector<double>>& warm_start,
                                          const IncrementalUpdate& update) const {
  if (!spec_.per_drive_params().empty()) return IdentifyPerDrive(training, validation, warm_start);
  return IdentifyAtDriveValues(training, validation, warm_start, &update);
}

DriveOverrides OverridesFor(const std::vector<DriveValue>& values, const model::ModelSpec& spec) {
  DriveOverrides out;
  for (const DriveValue& v : values) {
    if (v.reference) continue;  // the reference drive's values are the parameter vector's
    const int i = spec.param_index(v.param);
    const model::EffectParam* ep = i >= 0 ? spec.effect_param(i) : nullptr;
    if (ep && ep->per_drive) out[v.drive_id].emplace_back(i, v.value);
  }
  return out;
}

void Identifier::set_drive_values(const std::vector<DriveValue>& values) {
  drive_values_ = values;
  drive_overrides_ = OverridesFor(values, spec_);
}

IdentificationResult Identifier::IdentifyAtDriveValues(const SegmentList& training, const SegmentList& validation,
                                                 const std::optional<std::vector<double>>& warm_start,
                                                 const IncrementalUpdate* update) const {
  IdentificationResult r;
  r.model = spec_.Describe();
  const auto t_start = std::chrono::steady_clock::now();
  // Wall time of the fit's phases, for the debug log (setup, solve, checks, optimum, held-out).
  double phase[5] = {0, 0, 0, 0, 0};
  auto lap = std::chrono::steady_clock::now();
  auto mark = [&](int k) {
    const auto now = std::chrono::steady_clock::now();
    phase[k] += std::chrono::duration<double>(now - lap).count();
    lap = now;
  };
  const FitSettings settings{config_, spec_, wheelbase_m_, drive_overrides_};
  const ParameterBox box = ParameterBox::Make(config_, spec_);
  const std::vector<double>& scale = box.scale;
  const std::vector<int>& free = box.free;
  std::vector<double> theta = box.Start(warm_start);
  FitProblem fit(settings, scale, theta.data());
  std::vector<Chunk>& chunks = fit.chunks;
  std::vector<const stats::Segment*>& chunk_segment = fit.chunk_segment;

  // Incremental update (docs/incremental.md): the training segments the prior holds enter the
  // fit as their chunks' quadratics; the others are simulated.
  std::optional<IncrementalPrior> inc;
  SegmentList simulated = training;
  if (update && update->prior && drive_overrides_.empty() &&
      update->prior->Compatible(r.model, scale, config_.chunk_s, config_.burn_in_s)) {
    inc.emplace(settings, *update->prior, theta);  // theta: the anchor along the prior's weak directions
    simulated = inc->Split(training);
  }
  const double sigma_rule = update && update->exact ? std::min(update->relinearize_sigma, kExactSigma)
                                                    : (update ? update->relinearize_sigma : 0.0);
  fit.Cut(simulated);
  if (chunks.empty() && (!inc || inc->segments().empty())) {
    r.reason = "no gated segment long enough for the dynamic fit";
    return r;
  }

  ceres::Problem& problem = fit.problem;
  // Outputs: a_y alone (weight 1: the classical fit), or a_y and the yaw rate, each divided by
  // the square root of its noise level sigma^2 tau, first at the start values, then (below) at
  // the solution, refitting once when the ratio of the two moved by more than 1.5x.
  // With a prior, its weights hold (the outputs must be the same as when it was built).
  size_t chunks_with_yaw = fit.ChunksWithYawRate();
  // A prior segment counts by its data, not by its quadratics: those of a prior built for a_y
  // alone hold no yaw-rate residuals even where the data have a yaw rate.
  if (inc) chunks_with_yaw += inc->ChunksWithYawRate();
  const bool two_outputs = config_.yaw_rate_output && chunks_with_yaw > 0;
  // The update fitted as the whole window instead (no prior); `note`, when given, says why.
  auto whole_window = [&](const char* note) {
    IncrementalUpdate whole = *update;
    whole.prior = nullptr;
    IdentificationResult w = IdentifyAtDriveValues(training, validation, warm_start, &whole);
    if (note) w.update = note;
    return w;
  };
  if (inc && two_outputs != (inc->window().weight_yaw_rate > 0)) return whole_window(nullptr);
  // While the new data outnumber the prior's chunks (the first updates of a window, with two
  // outputs), a whole-window fit costs at most about twice the update and estimates the output
  // weights from all the data at its own solution.
  if (inc && two_outputs && chunks.size() >= inc->NumChunks())
    return whole_window("incremental: more chunks to simulate than the prior holds, so fitted as the whole window");
  std::shared_ptr<OutputWeights>& weights = fit.weights;
  weights->yaw_rate = two_outputs ? 1.0 : 0.0;
  if (inc) *weights = {inc->window().weight_a_y, inc->window().weight_yaw_rate};
  auto& costs = fit.costs;
  fit.AddCosts();
  // An update on a prior keeps each new chunk's last evaluation with its Jacobian for the
  // statistics at the optimum (chunk_cost.h), up to kKeepLastBytes of them.
  if (inc) fit.KeepLastWithin(kKeepLastBytes);
  // With both outputs, the weights of the whole window: the new data's noise level per output at
  // the start values pooled with the prior's (its chunks' autocorrelation sums, unweighted), as a
  // full fit sets them from all the data. A prior that keeps each chunk's yaw-rate part is
  // re-weighted to them exactly (docs/incremental.md); an older one holds its own.
  if (inc) inc->ReweightToWindow(fit, two_outputs);
  // Stale prior segments (their linearisation points left behind by the estimate) are
  // relinearised in place: each chunk simulated once with its Jacobian at theta, its quadratic
  // replaced by the one there (a copy of the prior holds them). The fit then goes on with the
  // quadratics, a Gauss-Newton step on those chunks; where that step leaves them again, the
  // checks after the solve relinearise them at the new point. At a solution where no chunk is
  // stale the scores of all chunks sum to zero as in the whole-window fit.
  auto relinearize = [&](const std::vector<size_t>& stale) {
    return inc->Relinearize(stale, theta, scale, weights, two_outputs, r.chunks_relinearized);
  };
  const char* kNotRelinearized = "incremental: a prior chunk could not be relinearised (non-finite residuals), so fitted as the whole window";
  if (inc) {
    // At the start, the distance rule of an ordinary update even for an exact one: the start (the
    // last estimate) is not the solution, and the exact rule applies there (after the solve), so
    // relinearising every chunk here too would only be done again.
    if (!relinearize(inc->StaleSegments(theta, update->relinearize_sigma, inc->TakeMoments()))) return whole_window(kNotRelinearized);
    inc->SetQuadratic();
    problem.AddResidualBlock(&inc->quadratic(), nullptr, theta.data());
  }
  // The noise level of the (weighted) residuals at theta, pooled with the prior's chunks.
  auto noise_level = [&]() {
    if (!inc) return fit.NoiseLevel();
    std::vector<std::vector<double>> a, rr;
    fit.EvaluateSeries(a, rr);
    std::vector<double> acf(kAcfMaxLag + 1, 0.0);
    double n = AddSeriesSums(a, acf);  // in this order: the sums add up in it
    n += AddSeriesSums(rr, acf);
    n += inc->PoolSums(acf);
    return LevelOfSums(acf, n);
  };
  auto set_weights = [&]() { return fit.EstimateWeights(two_outputs); };
  if (!inc) set_weights();
  if (free.empty()) {
    r.reason = "every parameter is fixed";
    return r;
  }
  box.Constrain(problem, theta.data());
  EvidencePriors priors;
  priors.Build(settings, box, training, standstill_);
  priors.AddTo(problem, theta.data());
  // The priors' weight: the noise level of the residuals at theta (the scale of a residual's
  // information); taken again wherever the weights or the fit moved it.
  auto reweight_priors = [&]() {
    if (priors.empty()) return;
    priors.SetWeight(noise_level());
  };
  reweight_priors();

  WindowSolver solver(config_, box, theta.data(), inc.has_value());
  // Coarse start of a large fit without a prior: the solver first runs on every k-th chunk, about
  // coarse_chunks of them, then finishes on the whole window from there.
  if (!inc && solver.WantsCoarseStart(costs.size())) {
    const CoarseStart coarse = solver.SolveCoarse(fit, priors, [&]() {
      if (!set_weights()) return false;
      reweight_priors();
      return true;
    });
    r.coarse_iterations = coarse.iterations;
    r.coarse_start_used = coarse.used;
  }
  mark(0);
  const ceres::Solver::Summary& summary = solver.summary();
  r.iterations = solver.Solve(problem);
  if (two_outputs && !inc && summary.IsSolutionUsable() && set_weights()) {
    // The outputs' noise levels at the solution differ from those at the start: refit once.
    reweight_priors();
    r.iterations += solver.Solve(problem);
    spdlog::debug("two outputs: refitted with weights a_y {:.4g}, yaw rate {:.4g}", weights->a_y, weights->yaw_rate);
  }
  if (!priors.empty() && summary.IsSolutionUsable()) {
    // The priors' weight was the noise level at the start; refit once if the fit moved it much.
    const double w = noise_level();
    if (w > 0 && (w > 2 * priors.weight() || w < 0.5 * priors.weight())) {
      priors.SetWeight(w);
      r.iterations += solver.Solve(problem);
    }
  }
  // Incremental: if the solution left some prior segments' linearisation points, relinearise
  // them there and solve again (at most kRelinearizeRounds rounds; an update still unsettled
  // after them is fitted as the whole window).
  // The quadratics are also checked where it matters, on EG: a sample of the prior's chunks is
  // simulated at the solution, the error of their predicted scores (J'e) is scaled to the whole
  // prior, and the Newton step it implies moves EG by `shift`; beyond kEgCheck of EG's standard
  // deviation, every prior segment is relinearised (and the update solved again). The same sample
  // checks EG's variance (kSigmaCheck).
  bool settled = !inc;
  mark(1);
  for (int round = 0; inc && summary.IsSolutionUsable(); ++round) {
    // An exact update's rule applies at its first solution; after that the ordinary rule and the
    // exact update's tighter EG check.
    const IncrementalPrior::Moments pm = inc->TakeMoments();
    std::vector<size_t> stale = inc->StaleSegments(theta, round == 0 ? sigma_rule : update->relinearize_sigma, pm);
    const bool checked = stale.empty();
    // kRecheckSigma: the same quadratics (every segment of the prior in the fit) already passed the
    // check next to this solution.
    const bool recheck = checked && (update->exact || !inc->CheckedNear(theta, pm));
    const EgCheckResult check = recheck ? CheckEg(settings, box, *inc, pm, theta, weights, update->exact) : EgCheckResult{};
    if (!check.eg || !check.sigma) {
      for (size_t i = 0; i < inc->segments().size(); ++i) stale.push_back(i);
    }
    if (stale.empty()) {
      settled = true;
      break;
    }
    if (checked && round == 0 && !(check.shift <= kEgCheckHopeless))
      return whole_window("incremental: the EG check found the prior's quadratics far off, so fitted as the whole window");
    // An exact update whose EG check does not hold the quadratics' error to its tighter limits
    // relinearises every chunk again and solves again (also where only the variance is off: an
    // exact update ends on a solve).
    if (checked && check.eg && !update->exact) {
      // Only EG's variance is off: every prior chunk is relinearised at the solution for the
      // statistics below, without another solve (the step the fresh quadratics imply moves EG
      // by less than kEgCheck of its standard deviation: the check above).
      if (!relinearize(stale)) return whole_window(kNotRelinearized);
      settled = true;
      break;
    }
    if (round == kRelinearizeRounds) break;
    if (!relinearize(stale)) return whole_window(kNotRelinearized);
    inc->SetQuadratic();
    mark(2);
    r.iterations += solver.Solve(problem);
    mark(1);
  }
  mark(2);
  if (!settled && summary.IsSolutionUsable())
    return whole_window("incremental: the estimate still left the prior's linearisation points after the relinearisation rounds, "
                        "so fitted as the whole window");
  r.termination = ceres::TerminationTypeToString(summary.termination_type);
  if (!summary.IsSolutionUsable()) {
    r.reason = "solver failed: " + summary.message;
    return r;
  }

  const bool keep = update && update->keep;
  OptimumSums sums = SumAtOptimum(fit, inc ? &*inc : nullptr, theta, training, keep, two_outputs, r);
  if (!SetTrainingFit(sums, *weights, inc.has_value(), two_outputs, config_.threads, r)) return r;
  FitStatistics statistics(settings, box, theta, priors, sums, r);
  statistics.Covariance(inc.has_value());
  statistics.Estimates();
  statistics.BoundShift();
  statistics.EgCorrelations();
  statistics.Halves();
  statistics.Identifiability(two_outputs, chunks_with_yaw, chunks.size());

  mark(3);
  // The held-out RMSE: with a linearisation to keep (the incremental path), from the held-out
  // chunks' quadratics; otherwise, or if a held-out chunk cannot be evaluated, every held-out chunk
  // is simulated at the estimate.
  std::vector<LinearizedSegment> held_lin;
  const bool held_done = !validation.empty() && keep &&
                         HeldOutFromQuadratics(settings, box, validation, theta, inc ? &*inc : nullptr, sigma_rule,
                                               two_outputs, held_lin, r);
  if (!validation.empty() && !held_done) HeldOutBySimulation(settings, validation, two_outputs, r);
  mark(4);
  r.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  spdlog::debug("fit times: setup {:.3f} s, solve {:.3f} s ({} iterations), checks and relinearisation {:.3f} s, statistics at "
                "the optimum {:.3f} s, held-out RMSE {:.3f} s; {} chunks simulated, {} relinearised", phase[0], phase[1], r.iterations,
                phase[2], phase[3], phase[4], r.chunks_simulated, r.chunks_relinearized);
  r.valid = std::isfinite(r.eg_rad_per_mps2) && std::isfinite(r.eg_se_rad_per_mps2);
  if (!r.valid) r.reason = "non-finite EG or standard error";
  if (inc) {
    char how[200];
    std::snprintf(how, sizeof how, "incremental%s: %zu chunks simulated, %zu from the prior (%zu relinearisations)",
                  update->exact ? " (exact)" : "", r.chunks_simulated, r.chunks_from_prior, r.chunks_relinearized);
    r.update = how;
  }
  if (keep && r.valid) {
    // The next update's prior, in the training segments' order.
    auto lw = std::make_shared<LinearizedWindow>();
    lw->model = r.model;
    lw->scale = scale;
    lw->weight_a_y = weights->a_y;
    lw->weight_yaw_rate = weights->yaw_rate;
    lw->chunk_s = config_.chunk_s;
    lw->burn_in_s = config_.burn_in_s;
    lw->updates_since_full = inc && r.chunks_from_prior > 0 && !update->exact ? inc->window().updates_since_full + 1 : 0;
    lw->checked_at = theta;  // settled: checked there, exact there, or every chunk fresh
    std::map<const stats::Segment*, const LinearizedSegment*> kept;
    if (inc)
      for (const IncrementalPrior::Segment& ps : inc->segments()) kept[ps.seg] = ps.lin;
    std::map<const stats::Segment*, std::vector<size_t>> fresh;
    for (size_t ci = 0; ci < chunks.size(); ++ci) fresh[chunk_segment[ci]].push_back(ci);
    for (const stats::Segment* seg : training) {
      if (!seg) continue;
      LinearizedSegment ls;
      ls.drive_id = seg->drive_id;
      ls.t0_ns = seg->t0_ns;
      ls.samples = seg->samples.size();
      if (const auto k = kept.find(seg); k != kept.end()) {
        ls.chunks = k->second->chunks;
      } else if (const auto f = fresh.find(seg); f != fresh.end()) {
        for (size_t ci : f->second) ls.chunks.push_back(std::move(sums.simulated_lin[ci]));
      }
      if (!ls.chunks.empty()) lw->segments.push_back(std::move(ls));
    }
    for (LinearizedSegment& ls : held_lin)
      if (!ls.chunks.empty()) lw->held_out.push_back(std::move(ls));
    r.linearized = std::move(lw);
  }
  return r;
}

}  // namespace ndsid::identify
