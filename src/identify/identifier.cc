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
#include "half_estimates.h"
#include "incremental_prior.h"
#include "parallel.h"
#include "quadratic_prior.h"
#include "residual_sums.h"
#include "window_solve.h"

namespace ndsid::identify {

std::string CeresVersion() { return CERES_VERSION_STRING; }
namespace {

std::string DescribeDirection(const Eigen::VectorXd& v, const std::vector<int>& free, const model::ModelSpec& spec) {
  std::ostringstream os;
  os.precision(2);
  os << std::fixed;
  for (int k = 0; k < v.size(); ++k) {
    if (std::abs(v[k]) < 0.1) continue;
    os << (v[k] >= 0 ? " +" : " ") << v[k] << ' ' << spec.param_name(free[k]);
  }
  return os.str();
}

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
  const int np = spec_.num_params();
  const FitSettings settings{config_, spec_, wheelbase_m_, drive_overrides_};
  const ParameterBox box = ParameterBox::Make(config_, spec_);
  const std::vector<ParameterBox::Bound>& bounds = box.bounds;
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
  const std::vector<size_t>& n_a = fit.n_a;
  size_t& n_res = fit.n_res;
  size_t& n_res_a = fit.n_res_a;
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
  // One chunk's weighted residuals e and Jacobian jac (row-major, m x np) at theta; false where
  // they cannot be evaluated or are not finite.
  // w: other output weights than the fit's (the held-out chunks' unit weights).
  auto evaluate_at_theta = [&](const Chunk& c, std::vector<double>& e, std::vector<double>& jac,
                               std::shared_ptr<const OutputWeights> w = nullptr) {
    return settings.EvaluateAt(c, scale, w ? w : weights, theta, e, jac);
  };
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

  // Residuals and Jacobian at the optimum, accumulated per chunk: J'J, the per-chunk scores
  // (cluster-robust covariance) and the residual series (autocorrelation time).
  Eigen::MatrixXd jtj = Eigen::MatrixXd::Zero(np, np);
  std::vector<Eigen::VectorXd> chunk_scores;
  std::vector<std::vector<double>> chunk_residuals;
  double rss = 0, rss_a = 0, rss_r = 0;  // weighted (all), unweighted per output
  std::vector<std::vector<double>> series_a, series_r;
  const bool keep = update && update->keep;
  // The two halves of the window (alternate training drives, in drive order) for the checks of
  // the fit (half_estimates.h): each chunk's moments at the estimate go to its drive's half.
  std::map<int64_t, int> half_of_drive;
  {
    std::set<int64_t> ids;
    for (const stats::Segment* seg : training)
      if (seg) ids.insert(seg->drive_id);
    int k = 0;
    for (int64_t id : ids) half_of_drive[id] = k++ % 2;
  }
  HalfMoments halves[2];
  for (HalfMoments& h : halves) h.Init(np);
  for (const auto& [id, h] : half_of_drive) ++halves[h].drives;
  std::vector<LinearizedChunk> simulated_lin(keep ? costs.size() : 0);
  // Each chunk's residuals, J'J and score are computed on config_.threads threads, then added up
  // in chunk order (the same sums for any number of threads).
  struct AtOptimum {
    std::vector<double> e;
    Eigen::MatrixXd jtj;
    Eigen::VectorXd score;
  };
  std::vector<AtOptimum> at(costs.size());
  const double* params[] = {theta.data()};
  ParallelFor(costs.size(), config_.threads, [&](size_t ci) {
    const ChunkCost& cost = costs[ci]->full();
    const int m = cost.num_residuals();
    std::vector<double>& e = at[ci].e;
    std::vector<double> jac;
    if (!costs[ci]->TakeLast(theta.data(), e, jac)) {  // the solver's last evaluation is not this point's
      e.resize(static_cast<size_t>(m));
      jac.resize(static_cast<size_t>(m) * np);
      double* jacs[] = {jac.data()};
      cost.Evaluate(params, e.data(), jacs);
    }
    Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> J(jac.data(), m, np);
    at[ci].jtj = J.transpose() * J;  // the model output's Jacobian is -J: signs cancel here and below
    at[ci].score = J.transpose() * Eigen::Map<const Eigen::VectorXd>(e.data(), m);
    if (keep)  // this chunk's quadratic at the estimate: the next update's prior
      Linearize(simulated_lin[ci], theta, e, J, at[ci].jtj, at[ci].score, n_a[ci], *weights, two_outputs);
  });
  for (size_t ci = 0; ci < costs.size(); ++ci) {
    std::vector<double>& e = at[ci].e;
    Eigen::Map<const Eigen::VectorXd> ev(e.data(), static_cast<long>(e.size()));
    jtj += at[ci].jtj;
    halves[half_of_drive[chunk_segment[ci]->drive_id]].AddChunk(at[ci].jtj, at[ci].score);
    chunk_scores.push_back(std::move(at[ci].score));
    rss += ev.squaredNorm();
    const auto split = e.begin() + static_cast<long>(n_a[ci]);
    for (auto it = e.begin(); it != split; ++it) rss_a += (*it / weights->a_y) * (*it / weights->a_y);
    for (auto it = split; it != e.end(); ++it) rss_r += (*it / weights->yaw_rate) * (*it / weights->yaw_rate);
    // One series per output for the autocorrelation time (the two are not one time series).
    chunk_residuals.emplace_back(e.begin(), split);
    series_a.emplace_back(e.begin(), split);
    if (split != e.end()) {
      chunk_residuals.emplace_back(split, e.end());
      series_r.emplace_back(split, e.end());
    }
    std::vector<double>().swap(e);
  }
  r.chunks_simulated = chunks.size();
  for (const Chunk& c : chunks) r.train_hours += c.n * c.dt_s / 3600.0;
  // The prior's chunks: their quadratics at the estimate (J'J, score, sum of squares), their
  // per-output sums of squares and autocorrelation sums as when they were last simulated.
  std::vector<double> acf_a, acf_r;  // pooled autocorrelation sums (incremental only)
  if (inc) {
    for (const auto& e : series_a) AddAutocorrelationSums(e, acf_a);
    for (const auto& e : series_r) AddAutocorrelationSums(e, acf_r);
    for (const IncrementalPrior::Segment& ps : inc->segments()) {
      for (const LinearizedChunk& c : ps.lin->chunks) {
        const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> hc(c.jtj.data(), np, np);
        const Eigen::VectorXd d = Eigen::Map<const Eigen::VectorXd>(theta.data(), np) - Eigen::Map<const Eigen::VectorXd>(c.theta.data(), np);
        const Eigen::VectorXd score = Eigen::Map<const Eigen::VectorXd>(c.score.data(), np) + hc * d;
        jtj += hc;
        halves[half_of_drive[ps.seg->drive_id]].AddChunk(hc, score);
        chunk_scores.push_back(score);
        rss += std::max(0.0, c.rss + 2 * Eigen::Map<const Eigen::VectorXd>(c.score.data(), np).dot(d) + d.dot(hc * d));
        rss_a += c.rss_a_y;
        rss_r += c.rss_yaw_rate;
        n_res += c.n_a_y + c.n_yaw_rate;
        n_res_a += c.n_a_y;
        if (!c.acf_a_y.empty()) AddSums(c.acf_a_y, acf_a);
        if (!c.acf_yaw_rate.empty()) AddSums(c.acf_yaw_rate, acf_r);
        r.train_hours += (c.n_a_y + BurnInSamples(Chunk{nullptr, 0, ps.seg->dt_s, 0, nullptr, {}}, config_.burn_in_s)) *
                         ps.seg->dt_s / 3600.0;
        ++r.chunks_from_prior;
      }
    }
  }
  r.residuals_train = n_res_a;
  r.residuals_train_yaw = n_res - n_res_a;
  r.chunks = r.chunks_simulated + r.chunks_from_prior;
  r.rmse_train_mps2 = std::sqrt(rss_a / static_cast<double>(n_res_a));
  r.yaw_rate_output = two_outputs;
  if (inc) {
    r.noise_level_a_y = LevelOfSums(acf_a, static_cast<double>(n_res_a)) / (weights->a_y * weights->a_y);
    if (two_outputs) {
      r.rmse_train_yaw_radps = std::sqrt(rss_r / static_cast<double>(n_res - n_res_a));
      r.noise_level_yaw_rate = LevelOfSums(acf_r, static_cast<double>(n_res - n_res_a)) / (weights->yaw_rate * weights->yaw_rate);
    }
  } else if (two_outputs) {
    r.rmse_train_yaw_radps = std::sqrt(rss_r / static_cast<double>(n_res - n_res_a));
    r.noise_level_a_y = ResidualNoiseLevel(series_a, config_.threads) / (weights->a_y * weights->a_y);
    r.noise_level_yaw_rate = ResidualNoiseLevel(series_r, config_.threads) / (weights->yaw_rate * weights->yaw_rate);
  } else {
    r.noise_level_a_y = ResidualNoiseLevel(series_a, config_.threads);
  }
  if (two_outputs && r.noise_level_a_y > 0 && r.noise_level_yaw_rate > 0) {
    spdlog::debug("two outputs: fitted with the weight ratio yaw rate / a_y {:.4g}{}; the noise levels at the solution give {:.4g}",
                  weights->yaw_rate / weights->a_y, inc ? " (the prior's)" : "",
                  std::sqrt(r.noise_level_a_y / r.noise_level_yaw_rate));
  }
  if (inc) {
    r.floor_a_y_mps2 = SumsFloor(acf_a, static_cast<double>(n_res_a), weights->a_y);
    if (two_outputs) r.floor_yaw_radps = SumsFloor(acf_r, static_cast<double>(n_res - n_res_a), weights->yaw_rate);
  } else {
    r.floor_a_y_mps2 = SeriesFloor(series_a, two_outputs ? weights->a_y : 1.0);
    if (two_outputs) r.floor_yaw_radps = SeriesFloor(series_r, weights->yaw_rate);
  }
  if (!std::isfinite(r.rmse_train_mps2)) {
    r.reason = "non-finite residuals at the solution";
    return r;
  }

  // Covariance of the free parameters in theta space.
  const int nf = static_cast<int>(free.size());
  Eigen::MatrixXd jtj_f(nf, nf);
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) jtj_f(a, b) = jtj(free[a], free[b]);
  const double sigma2 = rss / std::max<double>(1.0, static_cast<double>(n_res) - nf);
  // Prior information in theta space (zero without priors).
  const Eigen::MatrixXd prior_info = priors.InformationTheta(free);

  // Gradient of EG with respect to theta (free base parameters), by forward-mode autodiff.
  using Jet6 = ceres::Jet<double, 6>;
  model::Params<Jet6> pj{Jet6(theta[0] * scale[0], 0), Jet6(theta[1] * scale[1], 1), Jet6(theta[2] * scale[2], 2),
                         Jet6(theta[3] * scale[3], 3), Jet6(theta[4] * scale[4], 4), Jet6(theta[5] * scale[5], 5)};
  const Jet6 eg = model::SelfSteerGradient(pj, wheelbase_m_);
  Eigen::VectorXd eg_grad = Eigen::VectorXd::Zero(nf);
  for (int a = 0; a < nf; ++a) {
    if (free[a] < model::kNumParams) eg_grad[a] = eg.v[free[a]] * scale[free[a]];
  }

  // Two honest covariances for autocorrelated residuals; the one more cautious about EG wins:
  // the classical one inflated by the residuals' integrated autocorrelation time, and (with
  // enough chunks) the cluster-robust sandwich over chunks.
  double tau = 0;
  if (inc) {
    std::vector<double> acf = acf_a;
    AddSums(acf_r, acf);
    tau = AutocorrelationTimeFromSums(acf);
  } else {
    tau = IntegratedAutocorrelationTime(chunk_residuals, config_.threads);
  }
  // Classical: (J'J / (sigma^2 tau) + P)^-1; sandwich bread: (J'J + sigma^2 tau P)^-1.
  const Eigen::MatrixXd jtj_inv = (jtj_f + sigma2 * tau * prior_info).completeOrthogonalDecomposition().pseudoInverse();
  Eigen::MatrixXd cov = jtj_inv * sigma2 * tau;
  char method[160];
  std::snprintf(method, sizeof method, "autocorrelation-corrected (tau=%.1f samples)", tau);
  spdlog::debug("fit: sigma^2 {:.4g} over {} residuals, tau {:.2f}, rss {:.5g}, {} chunks ({} from the prior)", sigma2, n_res, tau,
                rss, chunks.size() + r.chunks_from_prior, r.chunks_from_prior);
  r.se_method = method;
  const size_t g = chunk_scores.size();
  if (g >= 10) {
    Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(nf, nf);
    for (const Eigen::VectorXd& sc : chunk_scores) {
      Eigen::VectorXd sf(nf);
      for (int a = 0; a < nf; ++a) sf[a] = sc[free[a]];
      meat += sf * sf.transpose();
    }
    const Eigen::MatrixXd cov_cluster = jtj_inv * meat * jtj_inv * (static_cast<double>(g) / (g - 1.0));
    if (eg_grad.dot(cov_cluster * eg_grad) > eg_grad.dot(cov * eg_grad)) {
      cov = cov_cluster;
      r.se_method = "cluster-robust over " + std::to_string(g) + " chunks";
    }
  }

  // Parameters, standard errors, correlations.
  auto estimate = [&](int i) {
    ParameterEstimate pe;
    pe.name = spec_.param_name(i);
    pe.unit = spec_.param_unit(i);
    pe.value = theta[i] * scale[i];
    pe.fixed = bounds[i].fixed;
    pe.at_bound = !pe.fixed && AtBound(pe.value, bounds[i].lower, bounds[i].upper);
    for (int a = 0; a < nf; ++a) {
      if (free[a] == i) pe.se = std::sqrt(std::max(0.0, cov(a, a))) * scale[i];
    }
    return pe;
  };
  for (int i = 0; i < model::kNumParams; ++i) r.params[i] = estimate(i);
  for (int i = model::kNumParams; i < np; ++i) r.effect_params.push_back(estimate(i));
  r.correlation.assign(static_cast<size_t>(np * np), 0.0);
  for (int i = 0; i < np; ++i) r.correlation[static_cast<size_t>(i * np + i)] = 1.0;
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) {
      const double d = std::sqrt(cov(a, a) * cov(b, b));
      r.correlation[static_cast<size_t>(free[a] * np + free[b])] = d > 0 ? cov(a, b) / d : 0.0;
    }

  // EG and its standard error by the delta method.
  r.eg_rad_per_mps2 = eg.a;
  r.eg_se_rad_per_mps2 = std::sqrt(std::max(0.0, eg_grad.dot(cov * eg_grad)));
  r.eg_deg_per_g = model::EgToDegPerG(r.eg_rad_per_mps2);
  r.eg_se_deg_per_g = model::EgToDegPerG(r.eg_se_rad_per_mps2);
  // The box's pull on EG (the checks of the fit): the Newton step from the estimate with every
  // bound released, -(J'J + priors)^-1 g (g the gradient there, the data's scores and the priors'
  // pull: at an interior optimum 0 but for the parameters the box holds), and EG's move along it,
  // in total and for each parameter released alone.
  {
    Eigen::VectorXd grad = Eigen::VectorXd::Zero(np);
    for (const Eigen::VectorXd& sc : chunk_scores) grad += sc;
    Eigen::MatrixXd hp = Eigen::MatrixXd::Zero(np, np);
    priors.AddPull(theta.data(), grad, hp);
    Eigen::MatrixXd hf(nf, nf);
    Eigen::VectorXd gf(nf);
    for (int a = 0; a < nf; ++a) {
      gf[a] = grad[free[a]];
      for (int b = 0; b < nf; ++b) hf(a, b) = jtj_f(a, b) + hp(free[a], free[b]);
    }
    const Eigen::MatrixXd hinv = hf.completeOrthogonalDecomposition().pseudoInverse();
    const Eigen::VectorXd v = hinv * eg_grad;  // EG's move per unit of -gradient
    r.eg_bound_shift_rad_per_mps2 = -v.dot(gf);
    for (int a = 0; a < nf; ++a) {
      ParameterEstimate& pe = free[a] < model::kNumParams ? r.params[free[a]] : r.effect_params[free[a] - model::kNumParams];
      if (pe.at_bound) pe.eg_release_shift_rad_per_mps2 = -v[a] * gf[a];
    }
  }
  // Each parameter's correlation with EG (the checks of the fit: a bound that moves EG).
  {
    const Eigen::VectorXd cg = cov * eg_grad;
    const double var_eg = eg_grad.dot(cg);
    for (int a = 0; a < nf; ++a) {
      ParameterEstimate& pe = free[a] < model::kNumParams ? r.params[free[a]] : r.effect_params[free[a] - model::kNumParams];
      const double d = std::sqrt(std::max(0.0, cov(a, a)) * std::max(0.0, var_eg));
      pe.eg_correlation = d > 0 ? cg[a] / d : 0.0;
    }
  }
  // The halves (alternate training drives): their EGs for the checks of the fit, and sigma(EG)
  // widened where they disagree beyond kHalvesCoverZ combined sigma.
  r.eg_se_fit_rad_per_mps2 = r.eg_se_rad_per_mps2;
  if (halves[0].drives > 0 && halves[1].drives > 0) {
    HalvesContext hc;
    hc.theta = theta;
    hc.scale = scale;
    for (int i : free)
      if (!AtBound(theta[i] * scale[i], bounds[i].lower, bounds[i].upper)) hc.free.push_back(i);
    hc.prior_info = priors.InformationAll(np);
    hc.noise_level = sigma2 * tau;
    hc.wheelbase_m = wheelbase_m_;
    r.halves = EstimateHalves(halves[0], halves[1], hc);
    r.eg_se_rad_per_mps2 = HonestSigma(r.eg_se_fit_rad_per_mps2, r.halves->first, r.halves->second);
    r.eg_se_deg_per_g = model::EgToDegPerG(r.eg_se_rad_per_mps2);
    if (r.eg_se_rad_per_mps2 > r.eg_se_fit_rad_per_mps2)
      r.se_method += " x" + std::to_string(r.eg_se_rad_per_mps2 / r.eg_se_fit_rad_per_mps2).substr(0, 4) +
                     " (the halves' disagreement)";
  }

  // Identifiability: singular values of the column-scaled Jacobian over the free parameters.
  {
    Eigen::VectorXd d(nf);
    for (int a = 0; a < nf; ++a) d[a] = jtj_f(a, a) > 0 ? 1.0 / std::sqrt(jtj_f(a, a)) : 0.0;
    const Eigen::MatrixXd scaled = d.asDiagonal() * jtj_f * d.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(scaled);
    const Eigen::VectorXd ev = es.eigenvalues().cwiseMax(0.0);  // ascending
    const double smax = std::sqrt(ev[nf - 1]);
    IdentifiabilityReport& rep = r.identifiability;
    rep.singular_values.fill(0.0);
    for (int a = 0; a < std::min<int>(nf, model::kNumParams); ++a) rep.singular_values[a] = std::sqrt(ev[nf - 1 - a]);
    rep.condition_number = std::sqrt(ev[0]) > 0 ? smax / std::sqrt(ev[0]) : INFINITY;
    for (int a = 0; a < nf; ++a) {
      const double ratio = smax > 0 ? std::sqrt(ev[a]) / smax : 0.0;
      if (ratio < 1e-3) {
        rep.weak.push_back({ratio, "not determined by the data:" + DescribeDirection(es.eigenvectors().col(a), free, spec_)});
      }
    }
    if (config_.params[model::kMass].fixed) {
      rep.notes.push_back("m fixed at " + std::to_string(static_cast<int>(r.params[0].value)) +
                          " kg from configuration: (d_sw, v, a_y) determine only cv/m, ch/m, Jz/m, lv, is; EG depends on m/cv, m/ch only");
    } else {
      rep.notes.push_back("m free: scaling m, Jz, cv, ch together leaves a_y unchanged, so m is not determined (expect it in the weak directions); EG is still determined");
    }
    for (int a = 0; a < nf; ++a) {
      const ParameterEstimate& pe = free[a] < model::kNumParams ? r.params[free[a]] : r.effect_params[free[a] - model::kNumParams];
      if (pe.value != 0 && pe.se / std::abs(pe.value) > 0.1) {
        rep.notes.push_back(pe.name + " weakly determined (relative standard error " +
                            std::to_string(static_cast<int>(100 * pe.se / std::abs(pe.value))) + " %)");
      }
      if (pe.at_bound) rep.notes.push_back(pe.name + " ended on its bound");
    }
    if (two_outputs) {
      char note[320];
      std::snprintf(note, sizeof note,
                    "outputs: a_y and yaw rate (%zu of %zu chunks have a yaw rate), each weighted by 1/sqrt(sigma^2 tau): "
                    "a_y %.3g (m/s^2)^2, yaw rate %.3g (deg/s)^2 per sample",
                    chunks_with_yaw, chunks.size(), r.noise_level_a_y,
                    r.noise_level_yaw_rate * (180 / M_PI) * (180 / M_PI));
      rep.notes.push_back(note);
    } else if (config_.yaw_rate_output) {
      rep.notes.push_back("outputs: a_y alone (identification.outputs asks for the yaw rate, but no chunk has one)");
    }
    for (const std::string& n : priors.Notes(config_, spec_)) rep.notes.push_back(n);
  }

  mark(3);
  // The held-out RMSE. With a linearisation to keep (the incremental path), from the held-out
  // chunks' quadratics (LinearizedWindow::held_out: unweighted, both outputs' parts): those of
  // the prior where the estimate lies within the distance rule of all their segment's points
  // (as for the training segments), the others' simulated once with their Jacobian at the
  // estimate, which gives their exact sums there and their quadratics for the next update.
  // An update thus simulates only new or stale held-out data. Otherwise, or if a held-out chunk
  // cannot be evaluated, every held-out chunk is simulated at the estimate.
  std::vector<LinearizedSegment> held_lin;
  bool held_done = false;
  if (!validation.empty() && keep) {
    std::map<std::pair<int64_t, int64_t>, const LinearizedSegment*> held_prior;
    if (inc)
      for (const LinearizedSegment& ls : inc->window().held_out) held_prior[{ls.drive_id, ls.t0_ns}] = &ls;
    Eigen::MatrixXd h;
    double level = 0;
    if (!held_prior.empty()) {
      h = inc->Jtj();
      level = inc->Level();
    }
    const Eigen::Map<const Eigen::VectorXd> x(theta.data(), np);
    auto near = [&](const LinearizedSegment& ls) { return level > 0 && !IncrementalPrior::DistanceOf(ls, x, h, level).beyond(sigma_rule); };
    held_lin.resize(validation.size());
    std::vector<std::vector<Chunk>> cuts(validation.size());
    std::vector<std::pair<size_t, size_t>> jobs;  // (held-out segment, chunk) simulated with the Jacobian
    size_t reused = 0;
    for (size_t i = 0; i < validation.size(); ++i) {
      const stats::Segment* seg = validation[i];
      if (!seg) continue;
      held_lin[i].drive_id = seg->drive_id;
      held_lin[i].t0_ns = seg->t0_ns;
      held_lin[i].samples = seg->samples.size();
      const auto it = held_prior.find({seg->drive_id, seg->t0_ns});
      if (it != held_prior.end() && SameSegment(*it->second, *seg) && near(*it->second)) {
        held_lin[i].chunks = it->second->chunks;
        reused += it->second->chunks.size();
        continue;
      }
      cuts[i] = MakeChunks({seg}, config_.chunk_s, config_.burn_in_s, drive_overrides_);
      held_lin[i].chunks.resize(cuts[i].size());
      for (size_t k = 0; k < cuts[i].size(); ++k) jobs.emplace_back(i, k);
    }
    const auto unit = std::make_shared<OutputWeights>(OutputWeights{1.0, two_outputs ? 1.0 : 0.0});
    std::vector<char> ok(jobs.size(), 0);
    ParallelFor(jobs.size(), config_.threads, [&](size_t j) {
      const auto [i, k] = jobs[j];
      const Chunk& c = cuts[i][k];
      std::vector<double> e, jac;
      if (!evaluate_at_theta(c, e, jac, unit)) return;
      const long m = static_cast<long>(e.size());
      const Eigen::Map<const RowMajorMatrix> J(jac.data(), m, np);
      const Eigen::Map<const Eigen::VectorXd> ev(e.data(), m);
      Linearize(held_lin[i].chunks[k], theta, e, J, J.transpose() * J, J.transpose() * ev, c.n - BurnInSamples(c, config_.burn_in_s),
                *unit, two_outputs, false);
      ok[j] = 1;
    });
    if (std::all_of(ok.begin(), ok.end(), [](char v) { return v != 0; })) {
      // Each chunk's sums at theta from its quadratic, per output (the yaw rate's part kept
      // apart; none with a_y alone), added in segment and chunk order.
      double sa = 0, sr = 0;
      size_t na = 0, nr = 0;
      for (const LinearizedSegment& ls : held_lin) {
        for (const LinearizedChunk& c : ls.chunks) {
          const Eigen::VectorXd d = x - Eigen::Map<const Eigen::VectorXd>(c.theta.data(), np);
          const Eigen::Map<const RowMajorMatrix> hall(c.jtj.data(), np, np);
          const Eigen::Map<const Eigen::VectorXd> sall(c.score.data(), np);
          double qr = 0, ga = sall.dot(d), qa = d.dot(hall * d), gr = 0;
          if (!c.jtj_yaw_rate.empty()) {
            const Eigen::Map<const RowMajorMatrix> hr(c.jtj_yaw_rate.data(), np, np);
            gr = Eigen::Map<const Eigen::VectorXd>(c.score_yaw_rate.data(), np).dot(d);
            qr = d.dot(hr * d);
            ga -= gr;
            qa -= qr;
          }
          sa += std::max(0.0, c.rss_a_y + 2 * ga + qa);
          sr += std::max(0.0, c.rss_yaw_rate + 2 * gr + qr);
          na += c.n_a_y;
          nr += c.n_yaw_rate;
        }
      }
      r.residuals_validation = na;
      r.rmse_validation_mps2 = RootMean(sa, na);
      if (two_outputs) r.rmse_validation_yaw_radps = RootMean(sr, nr);
      held_done = true;
      r.held_out_from_prior = reused;
      r.held_out_linearized = jobs.size();
      spdlog::debug("held-out RMSE: {} chunks from their quadratics, {} simulated with their Jacobian", reused, jobs.size());
    } else {
      held_lin.clear();
    }
  }
  if (!validation.empty() && !held_done) {  // both outputs' held-out RMSE from one simulation of each chunk
    const ErrorSums s = SimulatedErrorSums(spec_, wheelbase_m_, MakeChunks(validation, config_.chunk_s, config_.burn_in_s, drive_overrides_),
                                           r.AllValues(), config_.burn_in_s, two_outputs, config_.threads);
    r.residuals_validation = s.na;
    r.rmse_validation_mps2 = RootMean(s.a, s.na);
    if (two_outputs) r.rmse_validation_yaw_radps = RootMean(s.r, s.nr);
  }
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
        for (size_t ci : f->second) ls.chunks.push_back(std::move(simulated_lin[ci]));
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
