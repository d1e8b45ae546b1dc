// The ranking's sums: the scoring model's residuals e and Jacobian A (scoring_model.h) over the
// chunks at the current fit, as the score tests read them: A'A, A'e, in total and per chunk (the
// chunk is the cluster of the robust variances: 50 Hz residuals are strongly autocorrelated),
// and the standstill evidence as pseudo-observations.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "ndsid/identify/chunks.h"
#include "ndsid/identify/identifier.h"
#include "per_drive_score.h"
#include "scoring_model.h"
#include "signatures.h"

namespace ndsid::discover {

// Two outputs: each output's residuals weighted by 1/sqrt(sigma^2 tau) of its own residuals at
// the current fit, as the fit weighs them; with one output (or a noise level not finite) 1.
struct OutputWeights {
  double a_y = 1.0;       // the a_y rows' weight
  double yaw_rate = 1.0;  // the yaw-rate rows' weight
  bool stacked = false;   // both outputs scored, stacked (Diagnosis::outputs "a_y and yaw rate")
};
OutputWeights WeighOutputs(const identify::Identifier& identifier, const std::vector<double>& params,
                           const std::vector<identify::Chunk>& chunks);

struct ScoreSums {
  Eigen::MatrixXd M;                          // A'A over every chunk (and the evidence rows)
  Eigen::VectorXd Ae;                         // A'e over every chunk (and the evidence rows)
  std::vector<Eigen::MatrixXd> chunk_M;       // per chunk A'A (the sandwich of the one-step's standard error)
  std::vector<Eigen::VectorXd> chunk_Ae;      // per chunk A'e: its cluster's score
  std::vector<std::vector<double>> chunk_residuals;  // per chunk the residuals as scored (weighted)
  double rss = 0;                             // of the residuals as scored (weighted, stacked)
  size_t n = 0;                               // their number
  double rss_a = 0;                           // of a_y's residuals, unweighted
  size_t n_a = 0;                             // their number
};

// Evaluates the scoring model on every chunk and sums its residuals and Jacobian; the per-drive
// scores and the signatures take their sums from the same evaluation.
ScoreSums SumChunks(const identify::Identifier& identifier, const ScoringModel& sm, const std::vector<identify::Chunk>& chunks,
                    const OutputWeights& weights, std::vector<PerDriveScore>& per_drive, SignatureSums& signatures);

// Standstill evidence (docs/two-outputs.md): each prior Identify would use becomes one
// pseudo-observation sqrt(w) (value - x) / sd of its parameter, in the a_y residuals' units (w
// their noise level sigma^2 tau), and its own cluster in the robust variance. So a standing
// car's mean a_y speaks for accel_bias in the ranking as it does in the fit. Its cluster's
// variance is the model-based one, w a a' (under the null its residual has variance w, the
// stops' standard error being in sd), not the realised (a r)^2: one cluster that carries a
// strong signal alone would make its own realised score the whole variance and hold |z| at
// about 1 however clear the evidence (a hidden 0.4 deg/s gyro offset read z -1.1 that way).
struct StandstillEvidence {
  std::vector<Eigen::VectorXd> rows;  // per prior used: its pseudo-observation's row a of A
  double w = 0;                       // the noise level w the rows are scaled with (0: none used)
  std::vector<identify::Identifier::StandstillPrior> priors;  // the priors used (Diagnosis::evidence)
};
// Adds the evidence rows to sums.M and sums.Ae. noise_level: sigma^2 tau of the residuals as scored.
StandstillEvidence AddStandstillEvidence(const identify::Identifier& identifier, const ScoringModel& sm,
                                         const std::vector<identify::Chunk>& chunks, double noise_level, ScoreSums& sums);

}  // namespace ndsid::discover
