#include "window_solve.h"

#include <spdlog/spdlog.h>

#include <algorithm>

#include "active_set.h"

namespace ndsid::identify {
namespace {

// The coarse start's solves (IdentificationConfig::coarse_min_chunks) stop after this many
// iterations each.
constexpr int kCoarseIterations = 25;

}  // namespace

WindowSolver::WindowSolver(const config::IdentificationConfig& config, const ParameterBox& box, double* theta,
                           bool carry_active)
    : config_(config), box_(box), theta_(theta), carry_active_(carry_active) {
  options_.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options_.max_num_iterations = config.max_iterations;
  options_.num_threads = config.threads;
  options_.function_tolerance = 1e-10;
  options_.parameter_tolerance = 1e-10;
  options_.gradient_tolerance = 1e-12;
  options_.logging_type = ceres::SILENT;
  // No projected line search after each trust-region step: Ceres runs one for every problem
  // with bounds, evaluating the cost and its Jacobian at the trial step before the step's own
  // evaluation, and it nearly always keeps the full step. The bounds still hold through the
  // step's projection, and the active set holds parameters that settle on them.
  options_.max_num_line_search_step_size_iterations = 0;
  // (SolveWithActiveSet holds only those of start_held that sit on a bound.)
  if (carry_active_) active_ = box.free;
}

int WindowSolver::Solve(const ceres::Solver::Options& options, ceres::Problem& problem, ceres::Solver::Summary& summary) {
  const ActiveSetSolve a = SolveWithActiveSet(options, problem, theta_, box_.size(), box_.fixed, summary, 2, 0,
                                              carry_active_ ? active_ : std::vector<int>{});
  if (carry_active_) active_ = a.held;
  if (a.rounds > 1)
    spdlog::debug("active set: {} rounds, {} iterations, {} held at the end, {} released{}", a.rounds, a.iterations,
                  a.held.size(), a.released.size(), a.fallback ? ", finished by a plain projected solve" : "");
  return static_cast<int>(a.iterations);
}

bool WindowSolver::WantsCoarseStart(size_t chunks) const {
  return config_.coarse_min_chunks > 0 && config_.coarse_chunks > 0 && chunks >= config_.coarse_min_chunks &&
         chunks >= 2 * config_.coarse_chunks;
}

// The optimum is the whole window's; the start only saves the whole window's early iterations,
// each a simulation of every chunk with derivatives. The same costs, bounds, fixed set and
// priors; the priors keep their weight, so they count relatively more on the subset, which moves
// only the start.
CoarseStart WindowSolver::SolveCoarse(FitProblem& fit, const EvidencePriors& priors, const std::function<bool()>& reweighted) {
  CoarseStart out;
  ceres::Problem coarse(FitProblem::ProblemOptions());
  const size_t n = fit.costs.size();
  const size_t stride = n / config_.coarse_chunks;
  for (size_t i = stride / 2; i < n; i += stride) coarse.AddResidualBlock(fit.costs[i].get(), nullptr, theta_);
  priors.AddTo(coarse, theta_);
  box_.Constrain(coarse, theta_);
  // A warm start may already be the whole window's optimum (the last fit); the subset's
  // solution, a subset's statistical scatter away, would then be the worse start. The start
  // kept is the one with the lower whole-window cost (one pass of residuals each, same weights).
  ceres::Problem::EvaluateOptions eval_options;
  eval_options.num_threads = config_.threads;
  double cost_start = 0, cost_coarse = 0;
  const std::vector<double> start(theta_, theta_ + box_.size());
  const bool evaluated = fit.problem.Evaluate(eval_options, &cost_start, nullptr, nullptr, nullptr);
  // Its solves are capped at kCoarseIterations: a subset that converges slowly (few chunks,
  // weakly determined directions) hands over where it is; the whole window finishes.
  ceres::Solver::Options coarse_options = options_;
  coarse_options.max_num_iterations = std::min(options_.max_num_iterations, kCoarseIterations);
  ceres::Solver::Summary coarse_summary;
  out.iterations = Solve(coarse_options, coarse, coarse_summary);
  bool use = evaluated && coarse_summary.IsSolutionUsable() &&
             fit.problem.Evaluate(eval_options, &cost_coarse, nullptr, nullptr, nullptr) && cost_coarse < cost_start;
  // With two outputs, the output weights are then estimated at the coarse solution (from every
  // chunk's residuals) instead of at the start values, and the subset refitted while they moved
  // by more than 1.5x (at most twice); the whole window then starts with weights near its own.
  // With one output the whole-window problem is the one it would be without the coarse start.
  // If a round's solve fails, theta goes back to the start below but the weights stay at the
  // estimate from the subset's solution; the whole window's own check at its solution (refit
  // once when the weights moved 1.5x) still applies.
  for (int round = 0; use && round < 2 && reweighted(); ++round) {
    out.iterations += Solve(coarse_options, coarse, coarse_summary);
    use = coarse_summary.IsSolutionUsable();
  }
  if (!use) std::copy(start.begin(), start.end(), theta_);
  out.used = use;
  spdlog::debug("coarse start on every {}th of {} chunks: {} iterations, {}; whole-window cost {:.8g} at the start, "
                "{:.8g} there: {}", stride, n, out.iterations,
                ceres::TerminationTypeToString(coarse_summary.termination_type), cost_start, cost_coarse,
                use ? "used" : "the start kept");
  return out;
}

}  // namespace ndsid::identify
