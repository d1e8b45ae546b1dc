// The sums over every training chunk at a fit's optimum (private to the identify stage): the
// simulated chunks' residuals and Jacobians there, the prior's chunks' quadratics (incremental),
// and the training fit they give (RMSE, noise level and noise floor of each output).
#pragma once

#include <Eigen/Dense>

#include <cstddef>
#include <vector>

#include "fit_problem.h"
#include "half_estimates.h"
#include "incremental_prior.h"

namespace ndsid::identify {

struct OptimumSums {
  Eigen::MatrixXd jtj;                                // J'J over every chunk (theta space, np x np)
  std::vector<Eigen::VectorXd> chunk_scores;          // each chunk's score J'e: the simulated ones, then the prior's
  std::vector<std::vector<double>> chunk_residuals;   // the simulated chunks' residuals, one series per chunk and output
  std::vector<std::vector<double>> series_a, series_r;  // the same, a_y's and the yaw rate's apart
  double rss = 0;                                     // weighted residuals' sum of squares (both outputs)
  double rss_a = 0, rss_r = 0;                        // unweighted, per output
  size_t n_res = 0, n_res_a = 0;                      // residuals (both outputs), of them a_y's
  std::vector<double> acf_a, acf_r;                   // pooled autocorrelation sums per output (incremental only)
  HalfMoments halves[2];                              // the window's two halves (alternate training drives)
  std::vector<LinearizedChunk> simulated_lin;         // each simulated chunk's quadratic at the optimum (when kept)
};

// The sums at theta, the optimum: each simulated chunk's residuals and Jacobian (the solver's last
// evaluation where it kept it, else evaluated there; on the configured threads, added in chunk
// order), then the prior's chunks' quadratics at theta (J'J, score, sum of squares) with their
// per-output sums of squares and autocorrelation sums as when they were last simulated. With
// `keep`, each simulated chunk's quadratic for the next update's prior. Counts the chunks and the
// training hours into r.
OptimumSums SumAtOptimum(const FitProblem& fit, const IncrementalPrior* prior, const std::vector<double>& theta,
                         const SegmentList& training, bool keep, bool two_outputs, IdentificationResult& r);

// The training fit from the sums: each output's RMSE, noise level (sigma^2 tau, unweighted) and
// noise floor (the white part of its residual), and the residual counts. False, with the reason,
// where the residuals are not finite.
bool SetTrainingFit(const OptimumSums& sums, const OutputWeights& weights, bool incremental, bool two_outputs, int threads,
                    IdentificationResult& r);

}  // namespace ndsid::identify
