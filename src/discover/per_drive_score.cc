#include "per_drive_score.h"

#include <algorithm>
#include <cmath>

#include "ndsid/identify/chunks.h"

namespace ndsid::discover {

void PerDriveScore::Add(int64_t drive, const Eigen::Map<const RowMajor>& A, const Eigen::Map<const Eigen::VectorXd>& e) {
  const auto [it, added] = index.emplace(drive, static_cast<int>(index.size()));
  if (added) {
    a_g.push_back(Eigen::VectorXd::Zero(A.cols()));
    g_g.push_back(0);
    g_e.push_back(0);
  }
  const int d = it->second;
  const Eigen::VectorXd g = A.col(col);
  a_g[static_cast<size_t>(d)] += A.transpose() * g;
  g_g[static_cast<size_t>(d)] += g.squaredNorm();
  g_e[static_cast<size_t>(d)] += g.dot(e);
}

CandidateScore PerDriveScore::Score(const Eigen::MatrixXd& M, const Eigen::VectorXd& Ae, std::vector<int> fitted, double rss,
                                    size_t n, const std::vector<std::vector<double>>& residuals, double z_threshold) const {
  if (!pinned && std::find(fitted.begin(), fitted.end(), col) == fitted.end()) fitted.push_back(col);
  const int nd = static_cast<int>(index.size()), nf = static_cast<int>(fitted.size());
  Eigen::MatrixXd JtJ(nf, nf);
  Eigen::VectorXd Jte(nf);
  for (int a = 0; a < nf; ++a) {
    Jte[a] = Ae[fitted[a]];
    for (int b = 0; b < nf; ++b) JtJ(a, b) = M(fitted[a], fitted[b]);
  }
  Eigen::MatrixXd JtG(nf, nd), GtG = Eigen::MatrixXd::Zero(nd, nd);
  Eigen::VectorXd Gte(nd);
  for (int d = 0; d < nd; ++d) {
    for (int f = 0; f < nf; ++f) JtG(f, d) = a_g[static_cast<size_t>(d)][fitted[f]];
    GtG(d, d) = g_g[static_cast<size_t>(d)];
    Gte[d] = g_e[static_cast<size_t>(d)];
  }
  const Eigen::MatrixXd B = JtJ.completeOrthogonalDecomposition().solve(JtG);
  const Eigen::MatrixXd P = GtG - JtG.transpose() * B;  // projected G'G
  const Eigen::VectorXd q = Gte - B.transpose() * Jte;  // projected G'e
  const auto cod = P.completeOrthogonalDecomposition();
  const Eigen::VectorXd eta = cod.solve(q);
  CandidateScore s;
  s.effect = effect;
  s.param = param + " spread (sd over drives)";
  s.unit = unit;
  s.drss = std::max(0.0, q.dot(eta));
  s.rmse_predicted = std::sqrt(std::max(0.0, rss - s.drss) / static_cast<double>(n));
  const double mean = eta.mean();
  double var = 0;
  for (int d = 0; d < nd; ++d) var += (eta[d] - mean) * (eta[d] - mean);
  s.one_step = nd > 1 ? std::sqrt(var / (nd - 1)) : 0.0;
  s.uniqueness = GtG.trace() > 0 ? P.trace() / GtG.trace() : 0.0;
  const double sigma2_tau = identify::ResidualNoiseLevel(residuals);
  const double dof = std::max<double>(1.0, static_cast<double>(cod.rank()));
  const double chi2 = sigma2_tau > 0 ? s.drss / sigma2_tau : 0.0;
  s.z_robust = (chi2 - dof) / std::sqrt(2 * dof);
  s.significant = s.z_robust > z_threshold;
  return s;
}

}  // namespace ndsid::discover
