#include "eg_check.h"

#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <limits>
#include <map>
#include <numeric>
#include <optional>
#include <utility>

#include "parallel.h"
#include "quadratic_prior.h"
#include "residual_sums.h"

namespace ndsid::identify {
namespace {

// The sample: about kEgCheckChunks prior chunks, evenly spread over the prior. Its error may move
// EG by at most kEgCheck of its standard deviation, and EG's variance by at most kSigmaCheck (its
// standard deviation by about half of it); an exact update's by kExactEgCheck (a twentieth of
// the 0.2 sigma every update keeps to the whole-window fit) and kExactSigmaCheck.
constexpr size_t kEgCheckChunks = 32;
constexpr double kEgCheck = 0.15;
constexpr double kSigmaCheck = 0.1;
constexpr double kExactEgCheck = 0.01;
constexpr double kExactSigmaCheck = 0.01;
// The sample is simulated in two interleaved halves; the first decides alone when it holds at
// least this many chunks and shows every error within its limit with kEgCheckClearZ of its
// standard errors to spare (EgCheckEstimates::clear).
constexpr size_t kEgCheckFirstHalfMin = 8;
// The step of the forward difference along the EG direction (theta is O(1): a relative step).
constexpr double kEps = 1e-6;

// One check: the EG direction, the sample, each sampled chunk's terms.
class EgCheck {
 public:
  EgCheck(const FitSettings& settings, const ParameterBox& box, const IncrementalPrior& prior,
          const IncrementalPrior::Moments& pm, const std::vector<double>& theta,
          const std::shared_ptr<const OutputWeights>& weights, bool exact)
      : settings_(settings), box_(box), prior_(prior), pm_(pm), theta_(theta), weights_(weights),
        np_(box.size()), eg_limit_(exact ? kExactEgCheck : kEgCheck), sigma_limit_(exact ? kExactSigmaCheck : kSigmaCheck) {}

  EgCheckResult Run();

 private:
  // The EG direction: v = H^-1 g over the free parameters (H the prior's J'J, g EG's gradient),
  // so that v . (score error) is the Newton step's move of EG, and v'Hv = g'H^-1 g. False where
  // it is zero or EG's standard deviation is not positive.
  bool FindDirection();
  // The sampled chunks (picks into all_), their segments cut, and theta moved along v.
  void PickSample();
  // Each sampled chunk of one half simulated at theta and at theta + eps v / |v|: its residuals e
  // and the directional derivative J v (forward difference), against its quadratic's
  // predictions: v . score (the EG check) and v' J'J v (the bread of EG's variance).
  void SimulateHalf(size_t half);
  // The estimates from the first half's samples or from all of them; none where a sampled chunk
  // could not be simulated.
  std::optional<EgCheckEstimates> Estimate(bool first_half) const;

  // One sampled chunk's terms (EgCheckSample), once simulated.
  struct Sample {
    bool used = false, ok = true;
    double vs = 0, vs_pred = 0, vhv = 0, vhv_pred = 0;
  };

  const FitSettings& settings_;
  const ParameterBox& box_;
  const IncrementalPrior& prior_;
  const IncrementalPrior::Moments& pm_;
  const std::vector<double>& theta_;  // the solution checked
  const std::shared_ptr<const OutputWeights>& weights_;
  const int np_;
  const double eg_limit_, sigma_limit_;  // the limits of EG's move [sigma] and of its variance's (relative)
  std::vector<std::pair<size_t, size_t>> all_;  // every prior chunk: (prior segment, chunk)
  Eigen::VectorXd v_;                           // the EG direction (np)
  double v_max_ = 0;                            // its largest entry's magnitude
  double g_hinv_g_ = 0;                         // g'H^-1 g
  double sd_ = 0;                               // EG's standard deviation from the prior
  std::vector<size_t> picks_;                   // the sample: indices into all_
  std::map<const stats::Segment*, std::vector<Chunk>> cut_segments_;  // the sampled chunks' segments, cut
  std::vector<double> moved_;                   // theta + eps v / |v|
  std::vector<Sample> samples_;                 // one per pick
};

EgCheckResult EgCheck::Run() {
  const auto& held = prior_.segments();
  for (size_t i = 0; i < held.size(); ++i)
    for (size_t k = 0; k < held[i].lin->chunks.size(); ++k) all_.emplace_back(i, k);
  if (all_.empty()) return {};
  if (!FindDirection()) return {false, false};
  PickSample();
  // The sample in two interleaved halves (picks 0, 2, 4, ... then 1, 3, 5, ...): the second is
  // simulated only when the first does not already show the quadratics' errors within the limits
  // with room for its own sampling error (EgCheckEstimates::clear); otherwise every pick decides.
  SimulateHalf(0);
  std::optional<EgCheckEstimates> est = Estimate(true);
  if (!est) return {false, false};
  const bool early = picks_.size() >= 2 * kEgCheckFirstHalfMin && est->clear(eg_limit_, sigma_limit_);
  if (!early) {
    SimulateHalf(1);
    est = Estimate(false);
    if (!est) return {false, false};
    if (est->sampled == 0) return {};
  }
  spdlog::debug("incremental: EG check over {} of {} prior chunks{}: the quadratics' error moves EG by {:.3g} sigma (+- {:.2g}), its "
                "variance by {:.3g} (bread) and {:.3g} (cluster meat)", est->sampled, all_.size(), early ? " (the first half sufficed)" : "",
                est->shift, est->shift_se, est->bread, est->meat);
  return {est->shift <= eg_limit_, est->bread <= sigma_limit_ && est->meat <= sigma_limit_, est->shift};
}

bool EgCheck::FindDirection() {
  const std::vector<int>& fr = box_.free;
  const int nf = static_cast<int>(fr.size());
  const Eigen::MatrixXd& h = pm_.h;
  const Eigen::VectorXd eg_g = EgGradientTheta(theta_, box_.scale, settings_.wheelbase_m, box_.FixedFlags());
  Eigen::MatrixXd hf(nf, nf);
  Eigen::VectorXd gf(nf);
  for (int a = 0; a < nf; ++a) {
    gf[a] = eg_g[fr[a]];
    for (int b = 0; b < nf; ++b) hf(a, b) = h(fr[a], fr[b]);
  }
  const Eigen::VectorXd vf = hf.completeOrthogonalDecomposition().pseudoInverse() * gf;
  v_ = Eigen::VectorXd::Zero(np_);
  for (int a = 0; a < nf; ++a) v_[fr[a]] = vf[a];
  v_max_ = v_.lpNorm<Eigen::Infinity>();
  g_hinv_g_ = gf.dot(vf);
  sd_ = std::sqrt(std::max(0.0, pm_.level * g_hinv_g_));
  return v_max_ > 0 && sd_ > 0;
}

void EgCheck::PickSample() {
  const size_t step = std::max<size_t>(1, all_.size() / kEgCheckChunks);
  for (size_t a = step / 2; a < all_.size(); a += step) picks_.push_back(a);
  for (size_t a : picks_) {
    const stats::Segment* seg = prior_.segments()[all_[a].first].seg;
    if (!cut_segments_.count(seg)) cut_segments_.emplace(seg, settings_.Cut(seg));
  }
  moved_ = theta_;
  for (int i = 0; i < np_; ++i) moved_[static_cast<size_t>(i)] += kEps * v_[i] / v_max_;
  samples_.resize(picks_.size());
}

void EgCheck::SimulateHalf(size_t half) {
  ParallelFor((picks_.size() + 1 - half) / 2, settings_.config.threads, [&](size_t h) {
    const size_t j = 2 * h + half;
    const auto [i, k] = all_[picks_[j]];
    const IncrementalPrior::Segment& held = prior_.segments()[i];
    const std::vector<Chunk>& cuts = cut_segments_.at(held.seg);
    if (k >= cuts.size()) return;
    Sample& out = samples_[j];
    out.used = true;
    const Chunk& c = cuts[k];
    const auto cost = settings_.CostOf(c, box_.scale, weights_);
    const size_t m = static_cast<size_t>(cost->num_residuals());
    std::vector<double> e0(m), e1(m);
    const double* p0[] = {theta_.data()};
    const double* p1[] = {moved_.data()};
    const auto finite = [](double x) { return std::isfinite(x); };
    if (!cost->Evaluate(p0, e0.data(), nullptr) || !cost->Evaluate(p1, e1.data(), nullptr) ||
        !std::all_of(e0.begin(), e0.end(), finite) || !std::all_of(e1.begin(), e1.end(), finite)) {
      out.ok = false;
      return;
    }
    const Eigen::Map<const Eigen::VectorXd> a0(e0.data(), static_cast<long>(m)), a1(e1.data(), static_cast<long>(m));
    const Eigen::VectorXd jv = (a1 - a0) * (v_max_ / kEps);
    const LinearizedChunk& lc = held.lin->chunks[k];
    const Eigen::Map<const RowMajorMatrix> hc(lc.jtj.data(), np_, np_);
    const Eigen::VectorXd d =
        Eigen::Map<const Eigen::VectorXd>(theta_.data(), np_) - Eigen::Map<const Eigen::VectorXd>(lc.theta.data(), np_);
    out.vs = jv.dot(a0);
    out.vs_pred = v_.dot(Eigen::Map<const Eigen::VectorXd>(lc.score.data(), np_) + hc * d);
    out.vhv = jv.squaredNorm();
    out.vhv_pred = v_.dot(hc * v_);
  });
}

std::optional<EgCheckEstimates> EgCheck::Estimate(bool first_half) const {
  std::vector<EgCheckSample> used;
  for (size_t j = 0; j < samples_.size(); j += first_half ? 2 : 1) {
    const Sample& x = samples_[j];
    if (!x.ok) return std::nullopt;
    if (x.used) used.push_back({x.vs, x.vs_pred, x.vhv, x.vhv_pred});
  }
  return EstimateEgCheck(used, all_.size(), sd_, g_hinv_g_);
}

}  // namespace

EgCheckResult CheckEg(const FitSettings& settings, const ParameterBox& box, const IncrementalPrior& prior,
                      const IncrementalPrior::Moments& pm, const std::vector<double>& theta,
                      const std::shared_ptr<const OutputWeights>& weights, bool exact) {
  return EgCheck(settings, box, prior, pm, theta, weights, exact).Run();
}

EgCheckEstimates EstimateEgCheck(const std::vector<EgCheckSample>& samples, size_t total, double sd, double g_hinv_g) {
  EgCheckEstimates out;
  const size_t n = samples.size();
  out.sampled = n;
  if (n == 0) return out;
  double shift = 0, bread = 0, meat = 0, meat_pred = 0;
  for (const EgCheckSample& x : samples) {
    shift += x.vs - x.vs_pred;
    bread += x.vhv - x.vhv_pred;
    meat += x.vs * x.vs - x.vs_pred * x.vs_pred;
    meat_pred += x.vs_pred * x.vs_pred;
  }
  const double up = static_cast<double>(total) / static_cast<double>(n);
  out.shift = std::abs(shift * up) / sd;
  out.bread = std::abs(bread * up) / g_hinv_g;
  const double ratio = meat_pred > 0 ? meat / meat_pred : 0.0;
  out.meat = std::abs(ratio);
  if (n < 2) return out;
  // Sample variances of the terms about their sample means; for the ratio, the jackknife (the
  // linearised ratio's standard error falls 20 % short at 16 skewed samples, the jackknife's
  // does not: EgCheck.StandardErrorsDescribeTheSpreadOverSamples).
  const double dn = static_cast<double>(n);
  const double mean_shift = shift / dn, mean_bread = bread / dn;
  double ss_shift = 0, ss_bread = 0;
  std::vector<double> leave_one_out;
  leave_one_out.reserve(n);
  for (const EgCheckSample& x : samples) {
    ss_shift += std::pow(x.vs - x.vs_pred - mean_shift, 2);
    ss_bread += std::pow(x.vhv - x.vhv_pred - mean_bread, 2);
    const double den = meat_pred - x.vs_pred * x.vs_pred;
    if (den > 0) leave_one_out.push_back((meat - (x.vs * x.vs - x.vs_pred * x.vs_pred)) / den);
  }
  const double t = static_cast<double>(total);
  out.shift_se = t * std::sqrt(ss_shift / (dn - 1) / dn) / sd;
  out.bread_se = t * std::sqrt(ss_bread / (dn - 1) / dn) / g_hinv_g;
  if (leave_one_out.size() == n) {
    const double mean = std::accumulate(leave_one_out.begin(), leave_one_out.end(), 0.0) / dn;
    double ss = 0;
    for (double r : leave_one_out) ss += (r - mean) * (r - mean);
    out.meat_se = std::sqrt((dn - 1) / dn * ss);
  } else {
    out.meat_se = std::numeric_limits<double>::infinity();  // one chunk carries all of the meat
  }
  return out;
}

bool EgCheckEstimates::clear(double eg_limit, double sigma_limit) const {
  return sampled >= 2 && shift + kEgCheckClearZ * shift_se <= eg_limit && bread + kEgCheckClearZ * bread_se <= sigma_limit &&
         meat + kEgCheckClearZ * meat_se <= sigma_limit;
}

}  // namespace ndsid::identify
