#include "optimum_sums.h"

#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <map>
#include <set>

#include "parallel.h"
#include "residual_sums.h"

namespace ndsid::identify {
namespace {

// The two halves of the window for the checks of the fit (half_estimates.h): alternate training
// drives, in drive order; with a single drive (one recording), its earlier and its later gated
// time, split at the segment start that balances their chunks best, when each half then has at
// least kClusterRobustMinChunks (fewer give a sigma that a drive's own variation overruns; clean
// data split 5 against 18 chunks read 3 combined sigma apart).

struct HalfSplit {
  std::map<int64_t, int> of_drive;  // two or more drives: each drive's half
  bool in_time = false;             // one drive: by the segments' start times
  int64_t split_ns = 0;             // ... the later half's first segment start
  int Of(const stats::Segment& seg) { return in_time ? (seg.t0_ns < split_ns ? 0 : 1) : of_drive[seg.drive_id]; }
};

// Each segment's chunks (simulated and the prior's), by the segment's start time.
std::map<int64_t, size_t> ChunksByStart(const FitProblem& fit, const IncrementalPrior* prior) {
  std::map<int64_t, size_t> out;
  for (const stats::Segment* seg : fit.chunk_segment)
    if (seg) ++out[seg->t0_ns];
  if (prior) {
    for (const IncrementalPrior::Segment& ps : prior->segments()) out[ps.seg->t0_ns] += ps.lin->chunks.size();
  }
  return out;
}

HalfSplit SplitHalves(const FitProblem& fit, const IncrementalPrior* prior, const SegmentList& training, HalfMoments (&halves)[2]) {
  HalfSplit split;
  std::set<int64_t> ids;
  for (const stats::Segment* seg : training)
    if (seg) ids.insert(seg->drive_id);
  if (ids.size() >= 2) {
    int k = 0;
    for (int64_t id : ids) split.of_drive[id] = k++ % 2;
    for (const auto& [id, h] : split.of_drive) ++halves[h].drives;
    return split;
  }
  const std::map<int64_t, size_t> chunks = ChunksByStart(fit, prior);
  size_t total = 0;
  for (const auto& [t0, n] : chunks) total += n;
  size_t before = 0;
  double best = INFINITY;
  for (const auto& [t0, n] : chunks) {
    const size_t after = total - before;
    const double imbalance = std::abs(static_cast<double>(before) - static_cast<double>(after));
    if (before >= kClusterRobustMinChunks && after >= kClusterRobustMinChunks && imbalance < best) {
      best = imbalance;
      split.split_ns = t0;
      split.in_time = true;
    }
    before += n;
  }
  if (split.in_time) halves[0].drives = halves[1].drives = 1;
  else if (!ids.empty()) split.of_drive[*ids.begin()] = 0, halves[0].drives = 1;
  halves[0].in_time = halves[1].in_time = split.in_time;
  return split;
}

// One simulated chunk at the optimum.
struct AtOptimum {
  std::vector<double> e;  // its weighted residuals
  Eigen::MatrixXd jtj;    // J'J
  Eigen::VectorXd score;  // J'e
};

// Each simulated chunk's residuals, J'J and score, computed on the configured threads, then added
// up in chunk order (the same sums for any number of threads).
void SumSimulated(const FitProblem& fit, const std::vector<double>& theta, bool keep, bool two_outputs,
                  HalfSplit& half_of, OptimumSums& s) {
  const auto& costs = fit.costs;
  const int np = static_cast<int>(theta.size());
  const OutputWeights& weights = *fit.weights;
  s.simulated_lin.resize(keep ? costs.size() : 0);
  std::vector<AtOptimum> at(costs.size());
  const double* params[] = {theta.data()};
  ParallelFor(costs.size(), fit.settings.config.threads, [&](size_t ci) {
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
    Eigen::Map<const RowMajorMatrix> J(jac.data(), m, np);
    at[ci].jtj = J.transpose() * J;  // the model output's Jacobian is -J: signs cancel here and below
    at[ci].score = J.transpose() * Eigen::Map<const Eigen::VectorXd>(e.data(), m);
    if (keep)  // this chunk's quadratic at the estimate: the next update's prior
      Linearize(s.simulated_lin[ci], theta, e, J, at[ci].jtj, at[ci].score, fit.n_a[ci], weights, two_outputs);
  });
  for (size_t ci = 0; ci < costs.size(); ++ci) {
    std::vector<double>& e = at[ci].e;
    Eigen::Map<const Eigen::VectorXd> ev(e.data(), static_cast<long>(e.size()));
    s.jtj += at[ci].jtj;
    s.halves[half_of.Of(*fit.chunk_segment[ci])].AddChunk(at[ci].jtj, at[ci].score);
    s.chunk_scores.push_back(std::move(at[ci].score));
    s.rss += ev.squaredNorm();
    const auto split = e.begin() + static_cast<long>(fit.n_a[ci]);
    for (auto it = e.begin(); it != split; ++it) s.rss_a += (*it / weights.a_y) * (*it / weights.a_y);
    for (auto it = split; it != e.end(); ++it) s.rss_r += (*it / weights.yaw_rate) * (*it / weights.yaw_rate);
    // One series per output for the autocorrelation time (the two are not one time series).
    s.chunk_residuals.emplace_back(e.begin(), split);
    s.series_a.emplace_back(e.begin(), split);
    if (split != e.end()) {
      s.chunk_residuals.emplace_back(split, e.end());
      s.series_r.emplace_back(split, e.end());
    }
    std::vector<double>().swap(e);
  }
}

// The prior's chunks: their quadratics at the estimate (J'J, score, sum of squares), their
// per-output sums of squares and autocorrelation sums as when they were last simulated.
void SumPrior(const IncrementalPrior& prior, const std::vector<double>& theta, double burn_in_s,
              HalfSplit& half_of, OptimumSums& s, IdentificationResult& r) {
  const int np = static_cast<int>(theta.size());
  for (const auto& e : s.series_a) AddAutocorrelationSums(e, s.acf_a);
  for (const auto& e : s.series_r) AddAutocorrelationSums(e, s.acf_r);
  for (const IncrementalPrior::Segment& ps : prior.segments()) {
    for (const LinearizedChunk& c : ps.lin->chunks) {
      const Eigen::Map<const RowMajorMatrix> hc(c.jtj.data(), np, np);
      const Eigen::VectorXd d = Eigen::Map<const Eigen::VectorXd>(theta.data(), np) - Eigen::Map<const Eigen::VectorXd>(c.theta.data(), np);
      const Eigen::VectorXd score = Eigen::Map<const Eigen::VectorXd>(c.score.data(), np) + hc * d;
      s.jtj += hc;
      s.halves[half_of.Of(*ps.seg)].AddChunk(hc, score);
      s.chunk_scores.push_back(score);
      s.rss += std::max(0.0, c.rss + 2 * Eigen::Map<const Eigen::VectorXd>(c.score.data(), np).dot(d) + d.dot(hc * d));
      s.rss_a += c.rss_a_y;
      s.rss_r += c.rss_yaw_rate;
      s.n_res += c.n_a_y + c.n_yaw_rate;
      s.n_res_a += c.n_a_y;
      if (!c.acf_a_y.empty()) AddSums(c.acf_a_y, s.acf_a);
      if (!c.acf_yaw_rate.empty()) AddSums(c.acf_yaw_rate, s.acf_r);
      r.train_hours += (c.n_a_y + BurnInSamples(Chunk{nullptr, 0, ps.seg->dt_s, 0, nullptr, {}}, burn_in_s)) *
                       ps.seg->dt_s / 3600.0;
      ++r.chunks_from_prior;
    }
  }
}

}  // namespace

OptimumSums SumAtOptimum(const FitProblem& fit, const IncrementalPrior* prior, const std::vector<double>& theta,
                         const SegmentList& training, bool keep, bool two_outputs, IdentificationResult& r) {
  const int np = static_cast<int>(theta.size());
  OptimumSums s;
  s.jtj = Eigen::MatrixXd::Zero(np, np);
  s.n_res = fit.n_res;
  s.n_res_a = fit.n_res_a;
  for (HalfMoments& h : s.halves) h.Init(np);
  HalfSplit half_of = SplitHalves(fit, prior, training, s.halves);
  SumSimulated(fit, theta, keep, two_outputs, half_of, s);
  r.chunks_simulated = fit.chunks.size();
  for (const Chunk& c : fit.chunks) r.train_hours += c.n * c.dt_s / 3600.0;
  if (prior) SumPrior(*prior, theta, fit.settings.config.burn_in_s, half_of, s, r);
  return s;
}

bool SetTrainingFit(const OptimumSums& s, const OutputWeights& weights, bool incremental, bool two_outputs, int threads,
                    IdentificationResult& r) {
  const size_t n_res = s.n_res, n_res_a = s.n_res_a;
  r.residuals_train = n_res_a;
  r.residuals_train_yaw = n_res - n_res_a;
  r.chunks = r.chunks_simulated + r.chunks_from_prior;
  r.rmse_train_mps2 = std::sqrt(s.rss_a / static_cast<double>(n_res_a));
  r.yaw_rate_output = two_outputs;
  if (incremental) {
    r.noise_level_a_y = LevelOfSums(s.acf_a, static_cast<double>(n_res_a)) / (weights.a_y * weights.a_y);
    if (two_outputs) {
      r.rmse_train_yaw_radps = std::sqrt(s.rss_r / static_cast<double>(n_res - n_res_a));
      r.noise_level_yaw_rate = LevelOfSums(s.acf_r, static_cast<double>(n_res - n_res_a)) / (weights.yaw_rate * weights.yaw_rate);
    }
  } else if (two_outputs) {
    r.rmse_train_yaw_radps = std::sqrt(s.rss_r / static_cast<double>(n_res - n_res_a));
    r.noise_level_a_y = ResidualNoiseLevel(s.series_a, threads) / (weights.a_y * weights.a_y);
    r.noise_level_yaw_rate = ResidualNoiseLevel(s.series_r, threads) / (weights.yaw_rate * weights.yaw_rate);
  } else {
    r.noise_level_a_y = ResidualNoiseLevel(s.series_a, threads);
  }
  if (two_outputs && r.noise_level_a_y > 0 && r.noise_level_yaw_rate > 0) {
    spdlog::debug("two outputs: fitted with the weight ratio yaw rate / a_y {:.4g}{}; the noise levels at the solution give {:.4g}",
                  weights.yaw_rate / weights.a_y, incremental ? " (the prior's)" : "",
                  std::sqrt(r.noise_level_a_y / r.noise_level_yaw_rate));
  }
  if (incremental) {
    r.floor_a_y_mps2 = SumsFloor(s.acf_a, static_cast<double>(n_res_a), weights.a_y);
    if (two_outputs) r.floor_yaw_radps = SumsFloor(s.acf_r, static_cast<double>(n_res - n_res_a), weights.yaw_rate);
  } else {
    r.floor_a_y_mps2 = SeriesFloor(s.series_a, two_outputs ? weights.a_y : 1.0);
    if (two_outputs) r.floor_yaw_radps = SeriesFloor(s.series_r, weights.yaw_rate);
  }
  if (!std::isfinite(r.rmse_train_mps2)) {
    r.reason = "non-finite residuals at the solution";
    return false;
  }
  return true;
}

double SlowOutputFloorFactor(double interval_s, double rate_hz) {
  const double p = interval_s * rate_hz;
  return p > 1 && std::isfinite(p) ? p : 1.0;
}

}  // namespace ndsid::identify
