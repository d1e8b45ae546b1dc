// The ranking's score (Lagrange-multiplier) test of one candidate parameter: its sensitivity
// column g projected against the fitted parameters' columns J (what they cannot absorb), the
// predicted drop of the RSS and the one-step estimate from the projected column, the robust z from
// the chunks' scores, and what it is confounded with.
#pragma once

#include <Eigen/Dense>
#include <vector>

#include "ndsid/discover/diagnosis.h"
#include "score_sums.h"
#include "scoring_model.h"

namespace ndsid::discover {

// The projection against the fitted parameters, for every candidate column at once.
struct Projection {
  Eigen::MatrixXd JtJ;    // J'J (fitted x fitted)
  Eigen::MatrixXd JtG;    // J'G (fitted x candidates)
  Eigen::MatrixXd GtG;    // G'G (candidates x candidates)
  Eigen::VectorXd Jte;    // J'e
  Eigen::VectorXd Gte;    // G'e
  Eigen::MatrixXd B;      // (J'J)^-1 J'G: how the fitted parameters would absorb each candidate
  Eigen::MatrixXd Gt_Gt;  // projected G'G, G~ = G - J B
  Eigen::VectorXd Gt_e;   // projected G'e
};
Projection Project(const ScoreSums& sums, const std::vector<int>& fitted, const std::vector<int>& candidates);

// The score of sm.candidates[a]. rss, n: of the residuals as scored; noise_level: their sigma^2 tau.
CandidateScore ScoreCandidate(int a, const ScoringModel& sm, const ScoreSums& sums, const Projection& p,
                              const StandstillEvidence& evidence, double noise_level, double z_threshold);

}  // namespace ndsid::discover
