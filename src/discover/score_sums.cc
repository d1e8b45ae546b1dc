#include "score_sums.h"

#include <algorithm>
#include <cmath>
#include <set>

namespace ndsid::discover {

OutputWeights WeighOutputs(const identify::Identifier& identifier, const std::vector<double>& params,
                           const std::vector<identify::Chunk>& chunks) {
  OutputWeights w;
  if (!identifier.config().yaw_rate_output) return w;
  const double burn_in_s = identifier.config().burn_in_s;
  std::vector<std::vector<double>> ra, rr;
  for (identify::Chunk c : chunks) {
    const size_t burn = identify::BurnInSamples(c, burn_in_s);
    std::vector<double> e, jac;
    const auto own = identifier.drive_overrides().find(c.drive_id);  // the current model's layout
    c.drive_params = own != identifier.drive_overrides().end() ? own->second : std::vector<std::pair<int, double>>{};
    identify::EvaluateChunk(c, burn, identifier.wheelbase_m(), identifier.spec(), params, e, jac, true);
    const size_t na = c.n - burn;
    ra.emplace_back(e.begin(), e.begin() + static_cast<long>(std::min(na, e.size())));
    if (e.size() > na) rr.emplace_back(e.begin() + static_cast<long>(na), e.end());
  }
  const double la = identify::ResidualNoiseLevel(ra), lr = identify::ResidualNoiseLevel(rr);
  if (la > 0 && lr > 0 && std::isfinite(la) && std::isfinite(lr)) {
    w.a_y = 1.0 / std::sqrt(la);
    w.yaw_rate = 1.0 / std::sqrt(lr);
    w.stacked = true;
  }
  return w;
}

ScoreSums SumChunks(const identify::Identifier& identifier, const ScoringModel& sm, const std::vector<identify::Chunk>& chunks,
                    const OutputWeights& weights, std::vector<PerDriveScore>& per_drive, SignatureSums& signatures) {
  using RowMajor = PerDriveScore::RowMajor;
  const int np = sm.np;
  ScoreSums s;
  s.M = Eigen::MatrixXd::Zero(np, np);
  s.Ae = Eigen::VectorXd::Zero(np);
  for (const identify::Chunk& c : chunks) {
    const size_t burn = identify::BurnInSamples(c, identifier.config().burn_in_s);
    std::vector<double> e, jac;
    identify::EvaluateChunk(c, burn, identifier.wheelbase_m(), sm.big, sm.x, e, jac, weights.stacked);
    const size_t n_rows_a = std::min(c.n - burn, e.size());
    for (size_t k = 0; k < n_rows_a; ++k) s.rss_a += e[k] * e[k];
    s.n_a += n_rows_a;
    if (weights.stacked) {
      for (size_t k = 0; k < e.size(); ++k) {
        const double w = k < n_rows_a ? weights.a_y : weights.yaw_rate;
        e[k] *= w;
        for (int j = 0; j < np; ++j) jac[k * static_cast<size_t>(np) + static_cast<size_t>(j)] *= w;
      }
    }
    const int m = static_cast<int>(e.size());
    Eigen::Map<const RowMajor> A(jac.data(), m, np);
    Eigen::Map<const Eigen::VectorXd> ev(e.data(), m);
    s.chunk_M.push_back(A.transpose() * A);
    s.M += s.chunk_M.back();
    for (PerDriveScore& pds : per_drive) pds.Add(c.drive_id, A, ev);
    const Eigen::VectorXd ae = A.transpose() * ev;
    s.Ae += ae;
    s.chunk_Ae.push_back(ae);
    s.rss += ev.squaredNorm();
    s.n += static_cast<size_t>(m);
    s.chunk_residuals.push_back(e);
    signatures.AddChunk(c, burn, e, n_rows_a, weights.stacked ? weights.a_y : 1.0);
  }
  return s;
}

StandstillEvidence AddStandstillEvidence(const identify::Identifier& identifier, const ScoringModel& sm,
                                         const std::vector<identify::Chunk>& chunks, double noise_level, ScoreSums& sums) {
  StandstillEvidence ev;
  std::set<int64_t> drives;
  for (const identify::Chunk& c : chunks) drives.insert(c.drive_id);
  const double w = noise_level;
  for (const identify::Identifier::StandstillPrior& sp : identifier.StandstillPriors(drives)) {
    int col = -1;
    for (int i = model::kNumParams; i < sm.np; ++i)
      if (sm.big.param_name(i) == sp.param) col = i;
    if (col < 0 || !(w > 0)) continue;
    Eigen::VectorXd a = Eigen::VectorXd::Zero(sm.np);
    a[col] = -std::sqrt(w) / sp.sd;
    const double r = std::sqrt(w) * (sp.value - sm.x[static_cast<size_t>(col)]) / sp.sd;
    sums.M += a * a.transpose();
    sums.Ae += a * r;
    ev.rows.push_back(a);
    ev.w = w;
    ev.priors.push_back(sp);
  }
  return ev;
}

}  // namespace ndsid::discover
