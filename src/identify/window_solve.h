// The solves of a window fit (private to the identify stage): the solver's options, every solve
// with an active set (active_set.h), and the coarse start of a large fit without a prior.
#pragma once

#include <ceres/ceres.h>

#include <functional>
#include <vector>

#include "evidence_priors.h"
#include "fit_problem.h"

namespace ndsid::identify {

// What the coarse start did.
struct CoarseStart {
  int iterations = 0;  // of its solves
  bool used = false;   // its solution was the whole window's start (else the start was better)
};

// Every solve of one fit holds the parameters that settle on a bound (active_set.h): Ceres's
// projected steps crawl there. An incremental update starts at the last solution: the parameters
// it left on a bound are held from the first round (the KKT check releases them), and each solve
// of the update starts with the active set of the one before.
class WindowSolver {
 public:
  // carry_active: an incremental update (the active set carried from solve to solve).
  WindowSolver(const config::IdentificationConfig& config, const ParameterBox& box, double* theta, bool carry_active);

  // Solves the whole window's problem from theta; returns the iterations of all its rounds.
  int Solve(ceres::Problem& problem) { return Solve(options_, problem, summary_); }
  // The last whole-window solve's summary.
  const ceres::Solver::Summary& summary() const { return summary_; }
  bool usable() const { return summary_.IsSolutionUsable(); }

  // Whether a fit of `chunks` chunks without a prior starts on a subset (coarse_min_chunks).
  bool WantsCoarseStart(size_t chunks) const;
  // The coarse start: the solver first runs on every k-th chunk, about coarse_chunks of them
  // (interleaved over the whole window, so every part of it is represented), with the evidence
  // priors; theta is its solution where that lowers the whole window's cost, else it stays.
  // reweighted(): the output weights estimated at the subset's solution (and the priors
  // re-weighted); true where they moved enough for the subset to be refitted.
  CoarseStart SolveCoarse(FitProblem& fit, const EvidencePriors& priors, const std::function<bool()>& reweighted);

 private:
  int Solve(const ceres::Solver::Options& options, ceres::Problem& problem, ceres::Solver::Summary& summary);

  const config::IdentificationConfig& config_;
  const ParameterBox& box_;
  double* theta_;                   // the problems' only parameter block
  ceres::Solver::Options options_;  // the whole window's solves
  ceres::Solver::Summary summary_;  // of the last whole-window solve
  bool carry_active_;               // each solve starts with the active set of the one before
  std::vector<int> active_;         // the parameters held on a bound at the end of the last solve
};

}  // namespace ndsid::identify
