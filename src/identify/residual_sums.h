// Sums over chunks' residuals (private to the identify stage): a simulation's squared errors,
// pooled autocorrelation sums and the noise level and noise floor they give, and one chunk's
// quadratic (the incremental update's unit, linearized_window.h) from its residuals and Jacobian.
#pragma once

#include <Eigen/Dense>

#include <cstddef>
#include <vector>

#include "chunk_cost.h"
#include "ndsid/identify/chunks.h"
#include "ndsid/identify/linearized_window.h"

namespace ndsid::identify {

using RowMajorMatrix = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

// Adds factor * x into the pooled autocorrelation sums (lags 0..kAcfMaxLag).
void AddSums(const std::vector<double>& x, std::vector<double>& pooled, double factor = 1.0);

// Adds every series' autocorrelation sums into acf; returns the number of residuals.
double AddSeriesSums(const std::vector<std::vector<double>>& series, std::vector<double>& acf);

// sigma^2 tau of pooled autocorrelation sums over n residuals (acf[0] is their sum of squares).
double LevelOfSums(const std::vector<double>& acf, double n);

// The root mean square of n values from their sum of squares; -1 without values.
double RootMean(double sum, size_t n);

// The white part of residual series divided by `weight` (unweighted): sqrt(sum (e_k - e_k-1)^2 /
// 2n) within each series; -1 without pairs.
double SeriesFloor(const std::vector<std::vector<double>>& series, double weight);
// The same from pooled lag sums (acf[0] = sum e^2, acf[1] = sum e_k e_k-1) over n residuals.
double SumsFloor(const std::vector<double>& acf, double n, double weight);

// Squared errors of the simulated outputs against the measured ones, summed after each chunk's
// burn-in: a_y over every chunk and, with yaw_rate, the yaw rate over the chunks that have one.
// Each chunk is simulated once, on `threads` threads; the sums add up in chunk order.
struct ErrorSums {
  double a = 0, r = 0;
  size_t na = 0, nr = 0;
};
ErrorSums SimulatedErrorSums(const model::ModelSpec& spec, double wheelbase_m, const std::vector<Chunk>& chunks,
                             const std::vector<double>& params, double burn_in_s, bool yaw_rate, int threads);

// A chunk's quadratic at theta (the next update's prior) from its weighted residuals e (the
// n_a a_y ones first, then the yaw rate's), their Jacobian J and its J'J and score J'e.
void Linearize(LinearizedChunk& lc, const std::vector<double>& theta, const std::vector<double>& e,
               const Eigen::Ref<const RowMajorMatrix>& J, const Eigen::MatrixXd& jtj, const Eigen::VectorXd& score, size_t n_a,
               const OutputWeights& weights, bool two_outputs, bool with_acf = true);

}  // namespace ndsid::identify
