// Data adequacy, the termination signal (physics.md §3): EG's history against accumulated gated
// hours. Converged when EG's relative change over the last change window and its relative
// standard error both stay under the tolerance for a hold period, and coverage growth (KL
// divergence of the g-g / v-a_y histograms against one window ago) has flattened.
#pragma once

#include <deque>
#include <string>
#include <vector>

#include "ndsid/common/json_codec.h"
#include "ndsid/config/config.h"
#include "ndsid/stats/coverage.h"

namespace ndsid::adequacy {

enum class State { kCollecting = 0, kConverging = 1, kAdequate = 2 };
const char* StateName(State s);
// The state of a StateName() text; throws CodecError at `in` for any other text.
State StateFromJson(const JsonIn& in);

struct EgPoint {
  double gated_hours = 0;
  double eg = 0;     // rad/(m/s^2)
  double eg_se = 0;
  double kl = -1;    // coverage growth at this point, nats (-1: no earlier snapshot yet)
};

// A prior counted as driving before the first (docs/fleet.md, "Adequacy with a fleet
// prior"): worth `hours` gated hours of this vehicle's driving, EG `eg` at its means. Where EG's
// change window reaches back past the vehicle's first estimate into those hours, EG is compared
// with the prior's, and coverage growth is measured over the second half of the vehicle's own
// driving. The hold is counted in the vehicle's own hours. hours = 0: no prior (as without one).
struct PriorCredit {
  double hours = 0;
  double eg = 0;  // rad/(m/s^2)
};
// The credit of a fit whose priors hold `info_share` of EG's information (the rest from
// `data_hours` of the vehicle's own data): hours = data_hours * share / (1 - share), at most
// kMaxPriorHours; none without an EG of the priors (eg_prior = 0).
PriorCredit CreditOf(double info_share, double data_hours, double eg_prior);
inline constexpr double kMaxPriorHours = 1e4;

struct Report {
  State state = State::kCollecting;
  double gated_hours = 0;
  double rel_change = -1;      // |EG_now - EG_then| / |EG_now| over change_window_h (-1: not yet)
  double rel_se = -1;          // se / |EG|
  double kl_growth = -1;       // nats
  double hours_under_tolerance = 0;
  double prior_hours = 0;      // the prior's credit in hours (PriorCredit), 0 without one
  bool change_from_prior = false;  // rel_change measured against the prior's EG
  std::string explanation;     // the numbers behind the state, in words
};

class Tracker {
 public:
  explicit Tracker(const config::AdequacyConfig& config);

  // Record a new estimate (valid EG only) at the given accumulated gated hours; `prior`: the
  // credit of a fit started from priors (none by default).
  Report Update(double gated_hours, double eg, double eg_se, const stats::Coverage& coverage,
                const PriorCredit& prior = {});
  // Re-derive the report without a new estimate (e.g. after an identification failure).
  const Report& last() const { return last_; }
  // The newest kMaxHistoryPoints estimates (one per identification: decades of driving at the
  // default period); a state claiming more is rejected by FromJson.
  static constexpr size_t kMaxHistoryPoints = 100'000;
  const std::vector<EgPoint>& history() const { return history_; }

  static constexpr size_t kMaxSnapshots = 10'000;
  // The learned state (history, coverage snapshots, state): docs/state-format.md. FromJson
  // checks every value (finite, counts within the limits) and throws CodecError naming the
  // path of the first bad one, leaving this tracker unchanged.
  nlohmann::json ToJson() const;
  void FromJson(const JsonIn& in);

 private:
  double EgAt(double hours, bool& found) const;

  config::AdequacyConfig config_;
  std::vector<EgPoint> history_;
  struct Snapshot {
    double hours;
    stats::Coverage coverage;
  };
  std::deque<Snapshot> snapshots_;
  double under_since_hours_ = -1;
  Report last_;
};

}  // namespace ndsid::adequacy
