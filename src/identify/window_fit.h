// One fit of the model over the window with every drive's per-drive values held (private to the
// identify stage; Identifier::IdentifyAtDriveValues): the whole window, or an incremental update
// on a prior (docs/incremental.md). Run() is the algorithm as a short sequence of named steps;
// the state that travels between them is the members below, each with a comment (the model is
// Ceres's TrustRegionMinimizer). Each step returns false where the fit ends there, the result
// saying how (not valid with the reason, or the update fitted as the whole window).
//
// The numbers depend on two orders, which every step keeps: the sums add up in chunk order
// (parallel loops write per-chunk results, combined in index order), and the Ceres problem's
// residual blocks are added in a fixed order (the chunks, the prior's quadratic, the configured
// priors, the standstill evidence, the speed-scale evidence).
#pragma once

#include <chrono>
#include <cstddef>
#include <memory>
#include <optional>
#include <vector>

#include "eg_check.h"
#include "evidence_priors.h"
#include "fit_problem.h"
#include "incremental_prior.h"
#include "ndsid/identify/identifier.h"
#include "optimum_sums.h"
#include "window_solve.h"

namespace ndsid::identify {

class WindowFit {
 public:
  // update: null for a plain fit (no prior, no linearisation kept).
  WindowFit(const Identifier& identifier, const SegmentList& training, const SegmentList& validation,
            const std::optional<std::vector<double>>& warm_start, const IncrementalUpdate* update);

  IdentificationResult Run();

 private:
  // The steps of Run, in order.
  // The update's prior taken where it fits this model, the training segments it lacks cut into
  // chunks, the outputs chosen (a_y alone, or a_y and the yaw rate). False without data.
  bool CutWindow();
  // One cost per chunk with the start's output weights; on a prior, the prior re-weighted to the
  // whole window's weights, its stale segments relinearised at the start and its quadratic added;
  // without one, the output weights estimated at the start. False where a prior chunk could not
  // be relinearised (then fitted as the whole window).
  bool SetUpCosts();
  // The box on the problem, then the evidence priors and their weight. False where every
  // parameter is fixed.
  bool AddPriors();
  // The coarse start (a large fit without a prior), the solve, and one refit where the output
  // weights or the priors' weight moved at the solution.
  void Solve();
  // Incremental only: rounds of relinearising the prior segments the solution left and of the EG
  // check, each followed by a solve, until the solution settles on the quadratics. False where
  // the update is fitted as the whole window instead.
  bool SettleOnPrior();
  // Whether the last solve gave a usable solution (else not valid, with the solver's message).
  bool SolverSucceeded();
  // The sums at the optimum, the training fit, the covariance, estimates, EG ± sigma, the box's
  // pull on EG, the halves and the identifiability report. False where the residuals are not finite.
  bool ComputeStatistics();
  // The held-out RMSE, from the held-out chunks' quadratics (incremental) or by simulation.
  void EstimateHeldOut();
  // Validity, the update's description and, when asked, the next update's prior.
  void Finish();

  // The rules that end an update early and fit the whole window instead.
  // The prior was built for other outputs than the window's.
  bool PriorOutputsDiffer() const;
  // The new data outnumber the prior's chunks (the first updates of a window, with two outputs):
  // a whole-window fit costs at most about twice the update and estimates the output weights from
  // all the data at its own solution.
  bool NewDataOutnumberPrior() const;
  // The same quadratics (every segment of the prior in the fit) already passed the EG check next
  // to this solution (kRecheckSigma; never for an exact update).
  bool CheckedBefore(const IncrementalPrior::Moments& pm) const;
  // An EG check finds the quadratics' error moving EG by more than kEgCheckHopeless sigma (the
  // rounds seldom settle from so far: read at the first check).
  bool FarOff(const EgCheckResult& check) const;
  // Only EG's variance is off (an ordinary update): the prior is relinearised for the statistics
  // without another solve.
  bool OnlyVarianceOff(const EgCheckResult& check) const;
  // The priors' weight moved more than 2x at the solution: a refit is due.
  bool PriorsWeightMoved(double level) const;

  // The update fitted as the whole window (no prior); `note`, when given, says why. The Ends
  // set it as the result and return false (the step's end).
  IdentificationResult WholeWindow(const char* note) const;
  bool EndWholeWindow(const char* note);
  // The noise level of the (weighted) residuals at theta, pooled with the prior's chunks.
  double NoiseLevel() const;
  // The priors' weight taken again (the noise level at theta).
  void ReweightPriors();
  // With two outputs, the output weights estimated at theta and the priors re-weighted; true
  // where the weights moved by more than 1.5x.
  bool ReweightOutputs();
  bool Relinearize(const std::vector<size_t>& stale);
  // Every training chunk's quadratic at the estimate, in the training segments' order (the next
  // update's prior), with the held-out chunks' quadratics.
  std::shared_ptr<const LinearizedWindow> NextPrior();
  // Wall time since the last lap, added to the fit's phase k (the debug log).
  void Lap(int k);

  // What the fit reads.
  const Identifier& identifier_;                           // configuration, model, standstill stops
  const SegmentList& training_;
  const SegmentList& validation_;                          // held-out segments (RMSE only)
  const std::optional<std::vector<double>>& warm_start_;  // start values (else the configured ones)
  const IncrementalUpdate* update_;                        // null: a plain fit
  const FitSettings settings_;                             // what every part reads
  const ParameterBox box_;                                 // bounds, scaling, fixed and free parameters
  const bool keep_;                                        // return the linearisation (IncrementalUpdate::keep)
  const double sigma_rule_;                                // the distance rule at the first solution [prior sigma]
  const std::chrono::steady_clock::time_point start_;      // when the fit began (solve_seconds)

  // The algorithm's state, in the order the steps set it.
  IdentificationResult result_;               // filled step by step, returned by Run
  std::vector<double> theta_;                 // the scaled parameters p_i / scale_i: the problem's only parameter block
  FitProblem fit_;                            // the simulated chunks, their costs, the output weights, the Ceres problem
  std::optional<IncrementalPrior> prior_;     // the update's prior, where it fits this model
  size_t chunks_with_yaw_ = 0;                // training chunks whose data have a yaw rate (the prior's included)
  bool two_outputs_ = false;                  // the yaw rate is an output (configured, and the data have one)
  EvidencePriors priors_;                     // configured, standstill and speed-scale priors
  std::optional<WindowSolver> solver_;        // every solve (the active set carried on a prior)
  OptimumSums sums_;                          // the sums over every training chunk at the optimum
  std::vector<LinearizedSegment> held_lin_;   // the held-out chunks' quadratics (the next prior's held_out)
  std::chrono::steady_clock::time_point lap_;  // the last lap (Lap)
  double phase_s_[5] = {0, 0, 0, 0, 0};       // setup, solve, checks, optimum, held-out [s] (the debug log)
};

}  // namespace ndsid::identify
