// A bound-constrained least-squares solve with an active set (private to the identify stage).
#pragma once

#include <ceres/ceres.h>

#include <vector>

namespace ndsid::identify {

// What SolveWithActiveSet did.
struct ActiveSetSolve {
  int iterations = 0;            // Ceres iterations of every round
  int rounds = 0;                // solves run
  std::vector<int> held;         // parameters held on a bound in the last round
  std::vector<int> released;     // parameters released by the KKT check (each time)
  bool fallback = false;         // the rounds ran out: finished by one plain projected solve
};

// Solves `problem`, whose only parameter block is `theta` (np values, the box set on the problem,
// the parameters `fixed` held by a SubsetManifold), holding parameters that sit on a bound.
//
// Ceres handles a box by projecting its trust-region steps onto it. Where the optimum lies on a
// bound and the free parameters are correlated with the bounded one, the projected Gauss-Newton
// step is not the step of the remaining parameters: the step's predicted decrease is far from
// the actual one and the solver crawls (many iterations of small gain), or the projection undoes
// the step and the solver stops on "parameter tolerance" short of the optimum. Here:
// - a parameter that stayed on a bound for `hold_after` accepted iterations stops the solve,
//   and every parameter then on a bound is held there (SubsetManifold); the others are solved
//   again with exact Gauss-Newton steps;
// - when a solve converges (Ceres's own criteria), the gradient of the cost (Ceres's
//   1/2 sum r^2) is evaluated. Each parameter on a bound stays held unless its gradient points
//   into the box and freeing it alone would lower the cost by more than the solver's function
//   tolerance (g_i^2 / 2 H_ii, H the Gauss-Newton matrix); of several such, the one with the
//   largest gain is released (one at a time, as active-set methods do, so that they do not
//   go back and forth);
// - the problem is solved again until the held set no longer changes: the KKT conditions of
//   the box.
// After `max_rounds` solves (default 2 np + 2) without that, one plain projected solve finishes.
// `start_held` (a warm start's active set, e.g. the last solution's) are held from the first
// round where they sit on a bound at the start; the KKT check releases them as any other.
//
// On return the problem's manifold is the SubsetManifold of `fixed` (or none), and `summary` is
// that of the last solve.
ActiveSetSolve SolveWithActiveSet(const ceres::Solver::Options& options, ceres::Problem& problem, double* theta, int np,
                                  const std::vector<int>& fixed, ceres::Solver::Summary& summary, int hold_after = 2,
                                  int max_rounds = 0, const std::vector<int>& start_held = {});

}  // namespace ndsid::identify
