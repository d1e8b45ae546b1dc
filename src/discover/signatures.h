// The ranking's second look (Diagnosis::signatures, Diagnosis::unexplained): the a_y residual's
// correlation with signals that a missing effect would leave in it, whether or not the library
// has that effect (a bias, a scale, the tyre's nonlinearity, a lag, ...). Sums over the a_y
// residuals as scored (weighted with two outputs, the yaw-rate rows left out), clustered by chunk.
#pragma once

#include <Eigen/Dense>
#include <utility>
#include <vector>

#include "ndsid/discover/diagnosis.h"
#include "ndsid/identify/chunks.h"

namespace ndsid::discover {

class SignatureSums {
 public:
  // eg: the fit's self-steering gradient, for w(v) = v^2 / (l + EG v^2).
  SignatureSums(double wheelbase_m, double eg_rad_per_mps2);

  // One chunk: `e` its residuals as scored, the first `n_rows_a` of them a_y's (weighted by
  // `a_y_weight`, 1 unless two outputs are stacked), at the chunk's samples burn, burn + 1, ...
  void AddChunk(const identify::Chunk& c, size_t burn, const std::vector<double>& e, size_t n_rows_a, double a_y_weight);

  // The a_y residual's correlations (centred), by the drop in RSS each signal alone would give,
  // largest first.
  std::vector<SignatureCorrelation> Correlations() const { return a_y_.Correlations(); }
  // The same signals against the kinematic residual a_y,meas - v r_meas (no model in it, weighted
  // as the a_y residual is, so their slopes compare; empty
  // without a yaw rate): an a_y error's shape found there too is the accelerometer's (the car's
  // steering moves a_y and v r together), absent there a property of the car.
  std::vector<SignatureCorrelation> KinematicCorrelations() const { return kinematic_.Correlations(); }

 private:
  // One output's sums, clustered by chunk.
  struct OutputSums {
    explicit OutputSums(int signatures);
    void BeginChunk();
    void Add(const Eigen::VectorXd& x, double e);
    std::vector<SignatureCorrelation> Correlations() const;

    // The slope of e on signature s beside the constant and a_y, and its clustered standard error.
    std::pair<double, double> PartialSlope(int s) const;

    Eigen::MatrixXd sums;                    // per signature: sum x (column 0), sum x^2 (column 1)
    Eigen::MatrixXd xx;                      // sum x x' over all samples
    std::vector<Eigen::MatrixXd> chunk_xx;   // per chunk: sum x x'
    double sum_e = 0;                        // sum of the residuals as scored
    double rss = 0;                          // their sum of squares
    size_t n = 0;                            // their number
    std::vector<Eigen::VectorXd> chunk_xe;   // per chunk and signature: sum x e
    std::vector<double> chunk_e_sum;         // per chunk: sum e
  };

  double wheelbase_m_;  // l of w(v)
  double eg_;           // EG of w(v) [rad/(m/s^2)]
  OutputSums a_y_, kinematic_;
};

// Unexplained (Diagnosis::unexplained): a significant signature explains more than twice what
// the best significant candidate does, and more than 1 % of the RSS `rss`.
bool IsUnexplained(const SignatureCorrelation& top, double best_candidate_drss, double rss, double z_threshold);

// Sets d.unexplained and its text from d.ranked and d.signatures (both ranked already).
void JudgeUnexplained(Diagnosis& d, double rss, double z_threshold);

}  // namespace ndsid::discover
