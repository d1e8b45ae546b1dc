#include "score_test.h"

#include <algorithm>
#include <cmath>

namespace ndsid::discover {

Projection Project(const ScoreSums& sums, const std::vector<int>& fitted, const std::vector<int>& candidates) {
  const int nf = static_cast<int>(fitted.size()), nc = static_cast<int>(candidates.size());
  const Eigen::MatrixXd& M = sums.M;
  const Eigen::VectorXd& Ae = sums.Ae;
  Projection p;
  p.JtJ.resize(nf, nf);
  p.JtG.resize(nf, nc);
  p.GtG.resize(nc, nc);
  p.Jte.resize(nf);
  p.Gte.resize(nc);
  for (int a = 0; a < nf; ++a) {
    p.Jte[a] = Ae[fitted[a]];
    for (int b = 0; b < nf; ++b) p.JtJ(a, b) = M(fitted[a], fitted[b]);
    for (int b = 0; b < nc; ++b) p.JtG(a, b) = M(fitted[a], candidates[b]);
  }
  for (int a = 0; a < nc; ++a) {
    p.Gte[a] = Ae[candidates[a]];
    for (int b = 0; b < nc; ++b) p.GtG(a, b) = M(candidates[a], candidates[b]);
  }
  p.B = p.JtJ.completeOrthogonalDecomposition().solve(p.JtG);  // nf x nc
  p.Gt_Gt = p.GtG - p.JtG.transpose() * p.B;
  p.Gt_e = p.Gte - p.B.transpose() * p.Jte;
  return p;
}

namespace {

// What candidate a trades with: fitted parameters carrying most of its sensitivity (when little
// of it is its own), and candidates whose projected sensitivities are nearly parallel to its own.
std::vector<std::string> ConfoundedWith(int a, double uniqueness, const ScoringModel& sm, const Projection& p) {
  std::vector<std::string> out;
  const int nf = static_cast<int>(sm.fitted.size()), nc = static_cast<int>(sm.candidates.size());
  if (uniqueness < kConfoundedUniqueness) {
    for (int f = 0; f < nf; ++f) {
      const double share = std::abs(p.B(f, a)) * std::sqrt(p.JtJ(f, f) / std::max(p.GtG(a, a), 1e-300));
      if (share > 0.3) out.push_back(sm.big.param_name(sm.fitted[f]));
    }
  }
  for (int b = 0; b < nc; ++b) {
    if (b == a || p.Gt_Gt(a, a) <= 0 || p.Gt_Gt(b, b) <= 0) continue;
    const double corr = p.Gt_Gt(a, b) / std::sqrt(p.Gt_Gt(a, a) * p.Gt_Gt(b, b));
    if (std::abs(corr) > 0.9) out.push_back(sm.big.param_name(sm.candidates[b]));
  }
  return out;
}

}  // namespace

CandidateScore ScoreCandidate(int a, const ScoringModel& sm, const ScoreSums& sums, const Projection& p,
                              const StandstillEvidence& evidence, double noise_level, double z_threshold) {
  CandidateScore s;
  const int col = sm.candidates[static_cast<size_t>(a)];
  const model::EffectParam* ep = sm.big.effect_param(col);
  for (const auto& eff : sm.big.effects()) {
    for (const auto& prm : eff->info().params) {
      if (prm.name == ep->name) s.effect = eff->info().name;
    }
  }
  s.param = ep->name;
  s.unit = ep->unit;
  const double ztz = p.Gt_Gt(a, a), zte = p.Gt_e[a];
  s.uniqueness = p.GtG(a, a) > 0 ? ztz / p.GtG(a, a) : 0.0;
  if (ztz > 1e-12 * std::max(1.0, p.GtG(a, a))) {
    s.drss = zte * zte / ztz;
    s.one_step = ep->neutral - zte / ztz;
  }
  s.rmse_predicted = std::sqrt(std::max(0.0, sums.rss - s.drss) / static_cast<double>(sums.n));
  // The projected column z = e_col - sum_f B(f,a) e_fitted: per chunk, its score z'A'e and its
  // information z'A'Az.
  Eigen::VectorXd z = Eigen::VectorXd::Zero(sm.np);
  z[col] = 1.0;
  for (size_t f = 0; f < sm.fitted.size(); ++f) z[sm.fitted[f]] -= p.B(static_cast<int>(f), a);
  double var = 0, var_at_estimate = 0;
  for (size_t k = 0; k < sums.chunk_Ae.size(); ++k) {
    const double sc = z.dot(sums.chunk_Ae[k]);
    var += sc * sc;
    if (ztz > 0) {  // at the one-step estimate: the chunks' scores sum to zero
      const double at = sc - z.dot(sums.chunk_M[k] * z) * zte / ztz;
      var_at_estimate += at * at;
    }
  }
  double var_evidence = 0;
  for (const auto& row : evidence.rows) {
    const double sc = z.dot(row);
    var_evidence += evidence.w * sc * sc;
  }
  s.z_robust = var + var_evidence > 0 ? zte / std::sqrt(var + var_evidence) : 0.0;
  // The one-step's standard error, as the fit's covariance: model-based, or the cluster sandwich
  // at the estimate where that is larger.
  const double g = static_cast<double>(sums.chunk_Ae.size());
  if (s.drss > 0 && noise_level > 0 && std::isfinite(noise_level) && g > 1) {
    const double sandwich = var_at_estimate * g / (g - 1) + var_evidence;
    s.se = std::max(std::sqrt(noise_level / ztz), std::sqrt(sandwich) / ztz);
  }
  s.significant = std::abs(s.z_robust) > z_threshold;
  s.confounded_with = ConfoundedWith(a, s.uniqueness, sm, p);
  return s;
}

}  // namespace ndsid::discover
