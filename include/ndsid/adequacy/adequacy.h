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

struct Report {
  State state = State::kCollecting;
  double gated_hours = 0;
  double rel_change = -1;      // |EG_now - EG_then| / |EG_now| over change_window_h (-1: not yet)
  double rel_se = -1;          // se / |EG|
  double kl_growth = -1;       // nats
  double hours_under_tolerance = 0;
  std::string explanation;     // the numbers behind the state, in words
};

class Tracker {
 public:
  explicit Tracker(const config::AdequacyConfig& config);

  // Record a new estimate (valid EG only) at the given accumulated gated hours.
  Report Update(double gated_hours, double eg, double eg_se, const stats::Coverage& coverage);
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
