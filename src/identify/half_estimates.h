// EG of two disjoint halves of the window (alternate training drives; a single drive's earlier
// and later gated time), from the whole window's
// estimate without refitting: each half's chunks' Gauss-Newton moments at the estimate (J'J,
// scores J'e, and the scores' outer products for the cluster-robust variance) give its optimum by
// one Newton step, and its EG and standard error as the whole window's are computed. The whole
// window's estimate is stationary (its scores and its priors' gradient sum to zero), so the priors
// (configured, standstill, speed scale), which each half keeps, pull a half by minus the other
// half's scores: half a's step is (H_a + s2 P)^-1 g_b. The checks of the fit compare the two
// (fit_checks.h, "halves"); the published sigma(EG) is widened when they disagree (HonestSigma).
#pragma once

#include <Eigen/Dense>
#include <cstddef>
#include <string>
#include <vector>

#include "ndsid/identify/half_estimate.h"

namespace ndsid::identify {

// One half's sums over its chunks, at the whole window's estimate theta (theta space, every
// parameter of the model).
struct HalfMoments {
  Eigen::MatrixXd jtj;    // sum of J'J
  Eigen::VectorXd score;  // sum of J'e
  Eigen::MatrixXd meat;   // sum over chunks of (J'e)(J'e)'
  size_t chunks = 0;
  int drives = 0;
  bool in_time = false;  // the one drive's earlier or later gated time, not alternate drives
  void Init(int np) {
    jtj = Eigen::MatrixXd::Zero(np, np);
    score = Eigen::VectorXd::Zero(np);
    meat = Eigen::MatrixXd::Zero(np, np);
  }
  void AddChunk(const Eigen::MatrixXd& chunk_jtj, const Eigen::VectorXd& chunk_score) {
    jtj += chunk_jtj;
    score += chunk_score;
    meat += chunk_score * chunk_score.transpose();
    ++chunks;
  }
};

// What the halves need besides their moments.
struct HalvesContext {
  std::vector<double> theta;   // the whole window's estimate (theta space)
  std::vector<double> scale;   // p = theta * scale
  std::vector<int> free;       // the parameters free at the estimate (not fixed, not on a bound)
  Eigen::MatrixXd prior_info;  // the priors' information in theta space (np x np; zeros without priors)
  double noise_level = 0;      // sigma^2 tau of the weighted residuals
  double wheelbase_m = 0;
};

// The two halves' EG estimates; a half with no chunk, or whose step cannot be taken (singular,
// non-finite), is not valid with the reason.
std::pair<HalfEstimate, HalfEstimate> EstimateHalves(const HalfMoments& a, const HalfMoments& b, const HalvesContext& context);

// sigma(EG) widened so that the halves agree within kHalvesCoverZ combined sigma: the fit's own
// sigma times max(1, |z| / kHalvesCoverZ), z the halves' difference over their combined sigma.
// Returns the fit's sigma when either half is not valid.
inline constexpr double kHalvesCoverZ = 2.0;
double HonestSigma(double sigma_fit, const HalfEstimate& a, const HalfEstimate& b);

}  // namespace ndsid::identify
