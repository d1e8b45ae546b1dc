// A window fit's least-squares problem (private to the identify stage): what every part of a fit
// reads (FitSettings), the parameters' box and scaling (ParameterBox), and the simulated chunks
// with one Ceres cost each, sharing the output weights (FitProblem).
#pragma once

#include <ceres/ceres.h>

#include <cstddef>
#include <memory>
#include <optional>
#include <vector>

#include "chunk_cost.h"
#include "ndsid/identify/chunks.h"
#include "ndsid/identify/identifier.h"

namespace ndsid::identify {

// The configuration, the model and the per-drive values held: what every part of a fit reads.
struct FitSettings {
  const config::IdentificationConfig& config;
  const model::ModelSpec& spec;
  double wheelbase_m;
  const DriveOverrides& drive_overrides;  // every drive's per-drive values, held (Identifier::drive_overrides)

  // One segment cut into chunks as the fit cuts it (MakeChunks with the drives' values).
  std::vector<Chunk> Cut(const stats::Segment* segment) const;
  size_t BurnIn(const Chunk& c) const { return BurnInSamples(c, config.burn_in_s); }
  // One chunk's cost on theta (p_i = theta_i scale_i) with the output weights w.
  std::unique_ptr<ChunkCost> CostOf(const Chunk& c, const std::vector<double>& scale,
                                    std::shared_ptr<const OutputWeights> w) const;
  // One chunk's weighted residuals e and Jacobian jac (row-major, m x np) at theta; false where
  // they cannot be evaluated or are not finite.
  bool EvaluateAt(const Chunk& c, const std::vector<double>& scale, std::shared_ptr<const OutputWeights> w,
                  const std::vector<double>& theta, std::vector<double>& e, std::vector<double>& jac) const;
};

// Box, initial values and scaling of every parameter: base from configuration, effects from
// the effect library. theta_i = p_i / scale_i keeps every unknown O(1) for the solver.
struct ParameterBox {
  struct Bound {
    double lower, upper, initial;
    bool fixed;
  };
  std::vector<Bound> bounds;     // per parameter (the model's layout), in p
  std::vector<double> scale;     // p_i = theta_i * scale_i
  std::vector<int> fixed, free;  // the indices of the fixed and of the free parameters

  static ParameterBox Make(const config::IdentificationConfig& config, const model::ModelSpec& spec);
  int size() const { return static_cast<int>(bounds.size()); }
  std::vector<bool> FixedFlags() const;
  // theta at the start: the warm start's value of each free parameter (else its initial one),
  // clamped to the box.
  std::vector<double> Start(const std::optional<std::vector<double>>& warm_start) const;
  // The box and the fixed parameters of a problem on theta (the whole window's, the coarse start's).
  void Constrain(ceres::Problem& problem, double* theta) const;
};

// The simulated chunks of the window as one least-squares problem on theta: one cost per chunk
// (CompressedChunkCost), each output's residuals weighted by the shared OutputWeights. The
// problem's residual blocks are the costs in chunk order, then the prior's quadratic and the
// evidence priors (added by their owners).
struct FitProblem {
  // The problem's options: the costs stay owned here (the coarse start's problem shares them).
  static ceres::Problem::Options ProblemOptions();
  FitProblem(const FitSettings& settings, const std::vector<double>& scale, double* theta);

  // Cuts the segments into chunks, segment by segment (each chunk remembers its segment).
  void Cut(const SegmentList& segments);
  // One cost per chunk, in chunk order, added to the problem.
  void AddCosts();
  // Each cost keeps its last evaluation with its Jacobian for the statistics at the optimum
  // (chunk_cost.h) while they take at most `bytes` together.
  void KeepLastWithin(size_t bytes);
  size_t ChunksWithYawRate() const;
  // The chunk residuals at theta, one series per chunk and output: a_y series in `a`, yaw-rate
  // series in `r` (as weighted by the current weights).
  void EvaluateSeries(std::vector<std::vector<double>>& a, std::vector<std::vector<double>>& r) const;
  // sigma_e^2 * tau of the (weighted) chunk residuals at theta, each output's series separately.
  double NoiseLevel() const;
  // With two outputs, the weights from each output's unweighted noise level sigma^2 tau at theta
  // (kept where either is not positive and finite). True where the ratio of the two weights moved
  // by more than 1.5x (a refit is due); false with one output.
  bool EstimateWeights(bool two_outputs);

  const FitSettings& settings;
  const std::vector<double>& scale;  // the box's scaling (ParameterBox::scale)
  double* theta;                     // the problem's only parameter block
  std::vector<Chunk> chunks;                         // the simulated chunks, in segment order
  std::vector<const stats::Segment*> chunk_segment;  // the segment each chunk was cut from
  // The output weights every cost reads at each evaluation (re-weighting changes them all).
  std::shared_ptr<OutputWeights> weights = std::make_shared<OutputWeights>();
  std::vector<std::unique_ptr<CompressedChunkCost>> costs;  // one per chunk
  std::vector<size_t> n_a;  // a_y residuals per cost (the yaw-rate ones follow)
  size_t n_res = 0;         // residuals of every cost (both outputs)
  size_t n_res_a = 0;       // of them a_y's
  ceres::Problem problem;   // the costs, then the prior's quadratic and the evidence priors
};

}  // namespace ndsid::identify
