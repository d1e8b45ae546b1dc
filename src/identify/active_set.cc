#include "active_set.h"

#include <algorithm>
#include <cmath>
#include <memory>

namespace ndsid::identify {
namespace {

// theta_i on its box's lower or upper bound (Ceres clamps a projected step onto it exactly).
bool OnBound(const double* theta, const std::vector<double>& lower, const std::vector<double>& upper, size_t i) {
  return theta[i] <= lower[i] || theta[i] >= upper[i];
}

// Stops the solve once a free parameter has sat on a bound for `hold_after` accepted iterations.
class BoundWatch final : public ceres::IterationCallback {
 public:
  BoundWatch(const double* theta, const std::vector<double>& lower, const std::vector<double>& upper,
             const std::vector<bool>& movable, int hold_after)
      : theta_(theta), lower_(lower), upper_(upper), movable_(movable), hold_after_(hold_after),
        count_(lower.size(), 0) {}

  ceres::CallbackReturnType operator()(const ceres::IterationSummary& s) override {
    if (s.iteration == 0 || !s.step_is_successful) return ceres::SOLVER_CONTINUE;
    bool stop = false;
    for (size_t i = 0; i < count_.size(); ++i) {
      count_[i] = movable_[i] && OnBound(theta_, lower_, upper_, i) ? count_[i] + 1 : 0;
      stop = stop || count_[i] >= hold_after_;
    }
    return stop ? ceres::SOLVER_TERMINATE_SUCCESSFULLY : ceres::SOLVER_CONTINUE;
  }
  bool stopped_it() const {
    return std::any_of(count_.begin(), count_.end(), [&](int c) { return c >= hold_after_; });
  }

 private:
  const double* theta_;
  const std::vector<double>& lower_;
  const std::vector<double>& upper_;
  const std::vector<bool>& movable_;
  int hold_after_;
  std::vector<int> count_;
};

ceres::Manifold* HoldManifold(int np, const std::vector<int>& fixed, const std::vector<int>& held) {
  std::vector<int> all = fixed;
  all.insert(all.end(), held.begin(), held.end());
  std::sort(all.begin(), all.end());
  all.erase(std::unique(all.begin(), all.end()), all.end());
  return all.empty() ? nullptr : new ceres::SubsetManifold(np, all);
}

}  // namespace

ActiveSetSolve SolveWithActiveSet(const ceres::Solver::Options& options, ceres::Problem& problem, double* theta, int np,
                                  const std::vector<int>& fixed, ceres::Solver::Summary& summary, int hold_after,
                                  int max_rounds, const std::vector<int>& start_held) {
  ActiveSetSolve out;
  if (max_rounds <= 0) max_rounds = 2 * np + 2;
  const size_t n = static_cast<size_t>(np);
  std::vector<double> lower(n), upper(n);
  std::vector<bool> movable(n, true);
  for (int i = 0; i < np; ++i) {
    lower[static_cast<size_t>(i)] = problem.GetParameterLowerBound(theta, i);
    upper[static_cast<size_t>(i)] = problem.GetParameterUpperBound(theta, i);
  }
  for (int i : fixed) movable[static_cast<size_t>(i)] = false;
  const size_t n_movable = static_cast<size_t>(std::count(movable.begin(), movable.end(), true));
  std::vector<int> held;
  for (int i : start_held) {
    const size_t k = static_cast<size_t>(i);
    if (i >= 0 && k < n && movable[k] && OnBound(theta, lower, upper, k) && std::find(held.begin(), held.end(), i) == held.end())
      held.push_back(i);
  }
  std::sort(held.begin(), held.end());
  for (;;) {
    if (out.rounds >= max_rounds) {  // no KKT point in max_rounds: a plain projected solve finishes
      problem.SetManifold(theta, HoldManifold(np, fixed, {}));
      held.clear();
      ceres::Solve(options, &problem, &summary);
      out.iterations += static_cast<int>(summary.iterations.size());
      ++out.rounds;
      out.fallback = true;
      break;
    }
    std::vector<bool> watched = movable;
    for (int i : held) watched[static_cast<size_t>(i)] = false;
    BoundWatch watch(theta, lower, upper, watched, hold_after);
    ++out.rounds;
    if (held.size() < n_movable) {  // else every parameter is held: only the KKT check below
      ceres::Solver::Options o = options;
      o.update_state_every_iteration = true;
      o.callbacks.push_back(&watch);
      problem.SetManifold(theta, HoldManifold(np, fixed, held));
      ceres::Solve(o, &problem, &summary);
      out.iterations += static_cast<int>(summary.iterations.size());
      if (!summary.IsSolutionUsable()) break;
    }
    std::vector<int> on_bound;
    for (size_t i = 0; i < n; ++i)
      if (movable[i] && OnBound(theta, lower, upper, i)) on_bound.push_back(static_cast<int>(i));
    if (watch.stopped_it()) {
      // Stopped on the way: hold every parameter on a bound now. The gradient's sign at a point
      // not yet converged in the others says little; the check at convergence releases.
      held = on_bound;
      continue;
    }
    if (on_bound.empty() && held.empty()) break;  // an interior solution: Ceres's own
    // KKT: the gradient and the Gauss-Newton diagonal of every parameter at this point.
    problem.SetManifold(theta, nullptr);
    double cost = 0;
    std::vector<double> gradient;
    ceres::CRSMatrix jac;
    ceres::Problem::EvaluateOptions eo;
    eo.num_threads = options.num_threads;
    if (!problem.Evaluate(eo, &cost, nullptr, &gradient, &jac) || gradient.size() != n) {
      out.rounds = max_rounds;  // no gradient: finish as Ceres alone would
      continue;
    }
    std::vector<double> h(n, 0.0);
    for (size_t k = 0; k < jac.values.size(); ++k) h[static_cast<size_t>(jac.cols[k])] += jac.values[k] * jac.values[k];
    // Converged in the free parameters: every parameter on a bound stays held there, except the
    // one whose gradient points into the box with the largest gain from freeing it alone, if
    // that gain exceeds the solver's function tolerance (one at a time: freeing several at once
    // can send them back and forth).
    int release = -1;
    double best_gain = options.function_tolerance * cost;
    for (int j : on_bound) {
      const size_t i = static_cast<size_t>(j);
      const double g = gradient[i];
      const bool inward = (theta[i] >= upper[i] && g > 0) || (theta[i] <= lower[i] && g < 0);
      const double gain = h[i] > 0 ? g * g / (2 * h[i]) : 0.0;
      if (inward && gain > best_gain) {
        best_gain = gain;
        release = j;
      }
    }
    std::vector<int> next;
    for (int j : on_bound)
      if (j != release) next.push_back(j);
    if (release >= 0 && std::find(held.begin(), held.end(), release) != held.end()) out.released.push_back(release);
    if (next == held) break;  // converged in the free parameters; the held ones push outward
    held = next;
  }
  out.held = held;
  problem.SetManifold(theta, HoldManifold(np, fixed, {}));
  return out;
}

}  // namespace ndsid::identify
