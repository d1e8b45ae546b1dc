#include "scoring_model.h"

#include <algorithm>
#include <set>

namespace ndsid::discover {

bool SharesParameter(const model::EffectLibrary& library, const std::string& a, const std::string& b) {
  for (const auto& p : library.Get(a)->info().params)
    for (const auto& q : library.Get(b)->info().params)
      if (p.name == q.name) return true;
  return false;
}

std::vector<std::string> ChooseCandidates(const identify::Identifier& identifier, const DiagnosisOptions& options) {
  const model::ModelSpec& spec = identifier.spec();
  const bool defaults = options.candidates.empty() || options.candidates_extend_library;
  std::vector<std::string> candidates;
  const auto present = spec.effect_names();
  if (defaults) {
    for (const std::string& c : spec.library().builtin_names()) {
      const auto effect = spec.library().Find(c);
      if (effect == nullptr || effect->info().default_candidate) candidates.push_back(c);
    }
  }
  candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                  [&](const std::string& c) { return std::find(present.begin(), present.end(), c) != present.end(); }),
                   candidates.end());
  // Two outputs (identification.outputs [a_y, yaw_rate]): the score tests stack both outputs'
  // residuals, each weighted by 1/sqrt(its noise level), as the fit does; yaw-rate sensor effects
  // and the ones that need the yaw rate are then candidates too.
  // With a_y alone, a yaw-rate sensor effect reaches a_y only through an effect that reads the
  // measured yaw rate (road_bank's observer turns a gyro offset into a bank): then it is scored,
  // otherwise not; accel_scale (needs the yaw rate as an output) is not.
  const bool two_outputs = identifier.config().yaw_rate_output;
  const bool reads_r = std::any_of(spec.effects().begin(), spec.effects().end(),
                                   [](const auto& e) { return e->info().reads_measured_yaw_rate; });
  if (defaults && !two_outputs) {
    candidates.erase(std::remove_if(candidates.begin(), candidates.end(),
                                    [&](const std::string& c) {
                                      const auto builtin = model::BuiltinEffectNames();
                                      if (std::find(builtin.begin(), builtin.end(), c) == builtin.end()) return false;
                                      const model::ModelSpec one = model::ModelSpec::FromNames({c});
                                      return !one.effects().empty() && ((one.effects()[0]->info().yaw_rate_sensor && !reads_r) ||
                                                                        one.effects()[0]->info().needs_yaw_rate_output);
                                    }),
                     candidates.end());
  }
  // Listed names (added to the defaults, or replacing them) are scored whatever their kind.
  for (const std::string& c : options.candidates) {
    const bool listed = std::find(candidates.begin(), candidates.end(), c) != candidates.end();
    const bool in_model = std::find(present.begin(), present.end(), c) != present.end();
    if (!listed && !in_model) candidates.push_back(c);
  }
  return candidates;
}

ScoringModel BuildScoringModel(const identify::Identifier& identifier, const std::vector<double>& params,
                               const std::vector<std::string>& candidates, const DiagnosisOptions& options) {
  const model::ModelSpec& spec = identifier.spec();
  ScoringModel sm;
  // Alternatives (effects sharing a parameter: gyro_offset and gyro_offset_per_drive) enter it
  // once: a per-drive candidate whose parameter the model or an earlier candidate already has is
  // scored on that column, split by drive; any other such candidate is the model's own already.
  std::vector<std::string> all = spec.effect_names();
  for (const std::string& c : candidates) {
    if (std::none_of(all.begin(), all.end(), [&](const std::string& other) { return SharesParameter(spec.library(), c, other); })) {
      all.push_back(c);
      continue;
    }
    for (const auto& p : spec.library().Get(c)->info().params)
      if (p.per_drive) sm.alternatives.emplace_back(c, p.name);
  }
  sm.big = model::ModelSpec::FromNames(all, spec.library());
  sm.x = identify::Extend(spec, params, sm.big);
  sm.np = sm.big.num_params();
  const auto& cfg = identifier.config();
  for (int i = 0; i < sm.np; ++i) {
    const bool is_base = i < model::kNumParams;
    bool in_current = is_base;
    for (int j = model::kNumParams; j < spec.num_params() && !is_base; ++j) in_current |= spec.param_name(j) == sm.big.param_name(i);
    const model::EffectParam* ep = sm.big.effect_param(i);
    if (in_current) {
      if (ep && ep->pinned_at_reference()) continue;  // held at neutral on the reference drive
      if (options.hold_on_bound &&
          identify::AtBound(sm.x[static_cast<size_t>(i)], is_base ? cfg.params[i].lower : ep->lower,
                            is_base ? cfg.params[i].upper : ep->upper))
        continue;
      if (!(is_base && cfg.params[i].fixed)) sm.fitted.push_back(i);
    } else if (ep && ep->per_drive) {
      sm.per_drive.push_back(i);  // scored per drive (PerDriveScore)
    } else {
      sm.candidates.push_back(i);
    }
  }
  return sm;
}

std::vector<PerDriveScore> MakePerDriveScores(const ScoringModel& sm, const std::vector<identify::Chunk>& chunks) {
  std::vector<PerDriveScore> scores;
  std::set<int64_t> drives;
  for (const identify::Chunk& c : chunks) drives.insert(c.drive_id);
  if (drives.size() < 2) return scores;
  for (int col : sm.per_drive) {
    PerDriveScore pds;
    pds.col = col;
    pds.param = sm.big.param_name(col);
    pds.unit = sm.big.param_unit(col);
    for (const auto& eff : sm.big.effects())
      for (const auto& p : eff->info().params)
        if (p.name == pds.param) pds.effect = eff->info().name;
    pds.pinned = sm.big.effect_param(col)->pinned_at_reference();
    scores.push_back(std::move(pds));
  }
  for (const auto& [effect, param] : sm.alternatives) {
    PerDriveScore pds;
    pds.col = sm.big.param_index(param);
    pds.param = param;
    pds.unit = sm.big.param_unit(pds.col);
    pds.effect = effect;
    scores.push_back(std::move(pds));
  }
  return scores;
}

}  // namespace ndsid::discover
