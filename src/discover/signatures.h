// The ranking's second look (Diagnosis::signatures, Diagnosis::unexplained): the a_y residual's
// correlation with signals that a missing effect would leave in it, whether or not the library
// has that effect (a bias, a scale, the tyre's nonlinearity, a lag, ...). Sums over the a_y
// residuals as scored (weighted with two outputs, the yaw-rate rows left out), clustered by chunk.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "ndsid/discover/diagnosis.h"
#include "ndsid/identify/chunks.h"

namespace ndsid::discover {

class SignatureSums {
 public:
  // eg: the fit's self-steering gradient, for w(v) = v^2 / (l + EG v^2).
  SignatureSums(double wheelbase_m, double eg_rad_per_mps2);

  // One chunk: `e` its residuals as scored, the first `n_rows_a` of them a_y's, at the chunk's
  // samples burn, burn + 1, ...
  void AddChunk(const identify::Chunk& c, size_t burn, const std::vector<double>& e, size_t n_rows_a);

  // The correlations (centred), by the drop in RSS each signal alone would give, largest first.
  std::vector<SignatureCorrelation> Correlations() const;

 private:
  double wheelbase_m_;                     // l of w(v)
  double eg_;                              // EG of w(v) [rad/(m/s^2)]
  Eigen::MatrixXd sums_;                   // per signature: sum x (column 0), sum x^2 (column 1)
  double sum_e_ = 0;                       // sum of the a_y residuals as scored
  double rss_ = 0;                         // their sum of squares
  size_t n_ = 0;                           // their number
  std::vector<Eigen::VectorXd> chunk_xe_;  // per chunk and signature: sum x e
  std::vector<double> chunk_e_sum_;        // per chunk: sum e
};

// Unexplained (Diagnosis::unexplained): a significant signature explains more than twice what
// the best significant candidate does, and more than 1 % of the RSS `rss`.
bool IsUnexplained(const SignatureCorrelation& top, double best_candidate_drss, double rss, double z_threshold);

// Sets d.unexplained and its text from d.ranked and d.signatures (both ranked already).
void JudgeUnexplained(Diagnosis& d, double rss, double z_threshold);

}  // namespace ndsid::discover
