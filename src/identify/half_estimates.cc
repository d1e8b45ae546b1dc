#include "half_estimates.h"

#include <algorithm>
#include <cmath>

#include "ndsid/model/single_track.h"
#include "quadratic_prior.h"

namespace ndsid::identify {
namespace {

// The free parameters' block of m, and of v.
Eigen::MatrixXd Block(const Eigen::MatrixXd& m, const std::vector<int>& free) {
  const int nf = static_cast<int>(free.size());
  Eigen::MatrixXd out(nf, nf);
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) out(a, b) = m(free[a], free[b]);
  return out;
}
Eigen::VectorXd Part(const Eigen::VectorXd& v, const std::vector<int>& free) {
  Eigen::VectorXd out(static_cast<int>(free.size()));
  for (size_t a = 0; a < free.size(); ++a) out[static_cast<int>(a)] = v[free[a]];
  return out;
}

// Half `own`: one Newton step from theta on its chunks (the priors pulling by -other.score), its
// EG there and EG's standard error (the larger of the autocorrelation-corrected and, with 10 or
// more chunks, the cluster-robust one, as for the whole window).
HalfEstimate EstimateHalf(const HalfMoments& own, const HalfMoments& other, const HalvesContext& c) {
  HalfEstimate h;
  h.drives = own.drives;
  h.chunks = own.chunks;
  h.in_time = own.in_time;
  if (own.chunks == 0) {
    h.reason = "no chunk in this half";
    return h;
  }
  const int np = static_cast<int>(c.theta.size());
  const Eigen::MatrixXd hf = Block(own.jtj + c.noise_level * c.prior_info, c.free);
  const Eigen::VectorXd gf = Part(other.score, c.free);
  Eigen::LDLT<Eigen::MatrixXd> ldlt(hf);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-14)) {
    h.reason = "this half does not determine the free parameters";
    return h;
  }
  const Eigen::VectorXd step = ldlt.solve(gf);
  std::vector<double> at = c.theta;
  for (size_t a = 0; a < c.free.size(); ++a) at[static_cast<size_t>(c.free[a])] += step[static_cast<int>(a)];
  std::vector<bool> fixed(static_cast<size_t>(np), true);
  for (int i : c.free) fixed[static_cast<size_t>(i)] = false;
  double base[model::kNumParams];
  for (int i = 0; i < model::kNumParams; ++i) base[i] = at[static_cast<size_t>(i)] * c.scale[static_cast<size_t>(i)];
  h.eg_rad_per_mps2 = model::SelfSteerGradient(model::Params<double>::FromArray(base), c.wheelbase_m);
  const Eigen::VectorXd g = Part(EgGradientTheta(at, c.scale, c.wheelbase_m, fixed), c.free);
  if (!(g.squaredNorm() > 0)) {
    h.reason = "EG depends on no parameter free in this half (they are fixed or on their bounds)";
    return h;
  }
  const Eigen::VectorXd hinv_g = ldlt.solve(g);
  double var = c.noise_level * g.dot(hinv_g);
  if (own.chunks >= kClusterRobustMinChunks) {
    // The chunks' scores are taken at the whole window's estimate, where this half's sum to
    // own.score, not at its own optimum, where they sum to about zero: centred, their spread is
    // the half's, not the halves' disagreement (which would widen the very sigma that judges it).
    const double k = static_cast<double>(own.chunks);
    const Eigen::MatrixXd centred = own.meat - own.score * own.score.transpose() / k;
    const double cluster = hinv_g.dot(Block(centred, c.free) * hinv_g) * k / (k - 1);
    var = std::max(var, cluster);
  }
  h.eg_se_rad_per_mps2 = std::sqrt(std::max(0.0, var));
  h.valid = std::isfinite(h.eg_rad_per_mps2) && std::isfinite(h.eg_se_rad_per_mps2) && h.eg_se_rad_per_mps2 > 0;
  if (!h.valid) h.reason = "non-finite EG or standard error in this half";
  return h;
}

}  // namespace

std::pair<HalfEstimate, HalfEstimate> EstimateHalves(const HalfMoments& a, const HalfMoments& b, const HalvesContext& context) {
  return {EstimateHalf(a, b, context), EstimateHalf(b, a, context)};
}

double HonestSigma(double sigma_fit, const HalfEstimate& a, const HalfEstimate& b) {
  if (!a.valid || !b.valid) return sigma_fit;
  const double s = std::hypot(a.eg_se_rad_per_mps2, b.eg_se_rad_per_mps2);
  if (!(s > 0)) return sigma_fit;
  const double z = std::abs(a.eg_rad_per_mps2 - b.eg_rad_per_mps2) / s;
  return sigma_fit * std::max(1.0, z / kHalvesCoverZ);
}

}  // namespace ndsid::identify
