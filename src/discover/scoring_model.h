// The ranking's set-up: which candidates are scored, and the one model that holds them all. Its
// Jacobian at the current fit, every candidate at its neutral value, gives the fitted parameters'
// columns J and every candidate's sensitivity column at once (score_sums.h sums them).
#pragma once

#include <string>
#include <utility>
#include <vector>

#include "ndsid/discover/diagnosis.h"
#include "ndsid/identify/chunks.h"
#include "ndsid/model/model_spec.h"
#include "per_drive_score.h"

namespace ndsid::discover {

struct ScoringModel {
  model::ModelSpec big;    // the current model plus every candidate not an alternative (below)
  std::vector<double> x;   // the current fit extended to `big`, the candidates at their neutral values
  int np = 0;              // big.num_params()
  std::vector<int> fitted;     // big's columns the fit estimates (fixed, pinned ones and, with
                               // DiagnosisOptions::hold_on_bound, those on a bound left out)
  std::vector<int> candidates;  // big's columns of the candidates' parameters (scored one by one)
  std::vector<int> per_drive;   // big's columns of per-drive candidate parameters (PerDriveScore)
  // Alternatives: a per-drive candidate whose parameter the model or an earlier candidate already
  // has (gyro_offset_per_drive beside gyro_offset), scored on that column split by drive.
  std::vector<std::pair<std::string, std::string>> alternatives;  // (candidate, its parameter)
};

// Whether two effects of the library share a parameter: alternatives (gyro_offset and
// gyro_offset_per_drive), which one model never holds together.
bool SharesParameter(const model::EffectLibrary& library, const std::string& a, const std::string& b);

// The candidates the ranking scores (DiagnosisOptions::candidates, else the library's default
// candidates), less the model's own effects, and with a_y alone less the yaw-rate effects that
// cannot reach it.
std::vector<std::string> ChooseCandidates(const identify::Identifier& identifier, const DiagnosisOptions& options);

// The scoring model of `candidates` on top of the fit `params` of identifier.spec().
ScoringModel BuildScoringModel(const identify::Identifier& identifier, const std::vector<double>& params,
                               const std::vector<std::string>& candidates, const DiagnosisOptions& options);

// One PerDriveScore for each per-drive candidate and alternative, when `chunks` span two drives
// or more (none otherwise: one drive has no spread).
std::vector<PerDriveScore> MakePerDriveScores(const ScoringModel& sm, const std::vector<identify::Chunk>& chunks);

}  // namespace ndsid::discover
