// The ranking (diagnosis.h, Diagnose): the steps in order, each in its own unit.
//   1. the candidates and the one model holding them all      scoring_model.h
//   2. the output weights, the sums over the chunks at the fit  score_sums.h (per_drive_score.h,
//      and the standstill evidence                               signatures.h take their sums along)
//   3. each candidate's score test, then the per-drive ones     score_test.h, per_drive_score.h
//   4. the ranking by the predicted drop of the RSS             here
//   5. the signatures' correlations, and "unexplained"         signatures.h
#include "ndsid/discover/diagnosis.h"

#include <algorithm>
#include <cmath>

#include "ndsid/identify/chunks.h"
#include "per_drive_score.h"
#include "score_sums.h"
#include "score_test.h"
#include "scoring_model.h"
#include "signatures.h"

namespace ndsid::discover {
namespace {

// The a_y RMSE a candidate predicts: the stacked (weighted) RSS falls by drss, the a_y RMSE in
// proportion (with one output exactly sqrt((rss - drss) / n)). Then the candidates by drss,
// largest first.
void RankByPredictedDrop(Diagnosis& d, double rss) {
  for (CandidateScore& c : d.ranked) c.rmse_predicted = rss > 0 ? d.rmse * std::sqrt(std::max(0.0, 1.0 - c.drss / rss)) : 0.0;
  std::sort(d.ranked.begin(), d.ranked.end(), [](const auto& a, const auto& b) { return a.drss > b.drss; });
}

}  // namespace

Diagnosis Diagnose(const identify::Identifier& identifier, const std::vector<double>& params, const identify::SegmentList& segments,
                   const DiagnosisOptions& options) {
  Diagnosis d;
  d.model = identifier.spec().Describe();
  const ScoringModel sm = BuildScoringModel(identifier, params, ChooseCandidates(identifier, options), options);
  const auto& cfg = identifier.config();
  // The chunks carry the current per-drive values laid out for the scoring model.
  const auto chunks = identify::MakeChunks(segments, cfg.chunk_s, cfg.burn_in_s, identify::OverridesFor(identifier.drive_values(), sm.big));
  std::vector<PerDriveScore> per_drive = MakePerDriveScores(sm, chunks);
  const OutputWeights weights = WeighOutputs(identifier, params, chunks);
  if (weights.stacked) d.outputs = "a_y and yaw rate";
  const double eg = model::SelfSteerGradient(model::Params<double>::FromArray(params.data()), identifier.wheelbase_m());
  SignatureSums signatures(identifier.wheelbase_m(), eg);
  ScoreSums sums = SumChunks(identifier, sm, chunks, weights, per_drive, signatures);
  d.residuals = sums.n;
  d.rss = sums.rss;
  if (sums.n == 0) return d;
  d.rmse = sums.n_a > 0 ? std::sqrt(sums.rss_a / static_cast<double>(sums.n_a)) : 0.0;  // a_y, unweighted
  const double noise_level = identify::ResidualNoiseLevel(sums.chunk_residuals);  // sigma^2 tau of the residuals as scored
  const StandstillEvidence evidence = AddStandstillEvidence(identifier, sm, chunks, noise_level, sums);
  d.evidence = evidence.priors;

  const Projection projection = Project(sums, sm.fitted, sm.candidates);
  for (int a = 0; a < static_cast<int>(sm.candidates.size()); ++a) {
    d.ranked.push_back(ScoreCandidate(a, sm, sums, projection, evidence, noise_level, options.z_threshold));
  }
  for (const PerDriveScore& pds : per_drive) {
    d.ranked.push_back(pds.Score(sums.M, sums.Ae, sm.fitted, sums.rss, sums.n, sums.chunk_residuals, options.z_threshold));
  }
  RankByPredictedDrop(d, sums.rss);
  d.signatures = signatures.Correlations();
  d.kinematic_signatures = signatures.KinematicCorrelations();
  JudgeUnexplained(d, sums.rss, options.z_threshold);
  return d;
}

}  // namespace ndsid::discover
