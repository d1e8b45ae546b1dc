#include "ndsid/adequacy/adequacy.h"

#include <algorithm>
#include <cmath>

#include "ndsid/common/error.h"
#include "ndsid/common/format.h"

namespace ndsid::adequacy {

State StateFromJson(const JsonIn& in) {
  const std::string name = in.String();
  for (State st : {State::kCollecting, State::kConverging, State::kAdequate}) {
    if (name == StateName(st)) return st;
  }
  in.Fail("'" + name + "' is none of COLLECTING, CONVERGING, ADEQUATE");
}

const char* StateName(State s) {
  switch (s) {
    case State::kCollecting: return "COLLECTING";
    case State::kConverging: return "CONVERGING";
    case State::kAdequate: return "ADEQUATE";
  }
  return "?";
}

Tracker::Tracker(const config::AdequacyConfig& config) : config_(config) {}

// EG at an earlier point of the history (the newest estimate at or before `hours`).
double Tracker::EgAt(double hours, bool& found) const {
  found = false;
  double eg = 0;
  for (const EgPoint& p : history_) {
    if (p.gated_hours > hours + 1e-12) break;
    eg = p.eg;
    found = true;
  }
  return eg;
}

PriorCredit CreditOf(double info_share, double data_hours, double eg_prior) {
  if (!(info_share > 0) || !(data_hours > 0) || eg_prior == 0 || !std::isfinite(eg_prior)) return {};
  const double hours = info_share >= 1 ? kMaxPriorHours : std::min(kMaxPriorHours, data_hours * info_share / (1 - info_share));
  return {hours, eg_prior};
}

Report Tracker::Update(double hours, double eg, double eg_se, const stats::Coverage& coverage, const PriorCredit& prior) {
  Report r;
  r.gated_hours = hours;
  r.prior_hours = prior.hours;
  const double since = hours - config_.change_window_h;  // the change window's start
  // Coverage growth against the newest snapshot at least one change window old.
  const Snapshot* then = nullptr;
  for (const Snapshot& s : snapshots_) {
    if (s.hours <= since + 1e-12) then = &s;
  }
  bool found = false;
  double eg_then = EgAt(since, found);
  if (!found && prior.hours > 0 && prior.eg != 0 && since >= -prior.hours - 1e-12) {
    // The window reaches back past the first estimate into the prior's hours: EG against the
    // prior's, coverage growth over the second half of the vehicle's own driving.
    eg_then = prior.eg;
    found = true;
    r.change_from_prior = true;
    for (const Snapshot& s : snapshots_) {
      if (s.hours <= hours / 2 + 1e-12) then = &s;
    }
  }
  if (then) {
    r.kl_growth = std::max(stats::KlDivergence(coverage.gg(), then->coverage.gg()),
                           stats::KlDivergence(coverage.v_ay(), then->coverage.v_ay()));
  }
  if (found && eg != 0) r.rel_change = std::abs(eg - eg_then) / std::abs(eg);
  if (eg != 0) r.rel_se = eg_se / std::abs(eg);
  history_.push_back({hours, eg, eg_se, r.kl_growth});
  if (history_.size() > kMaxHistoryPoints) history_.erase(history_.begin());  // bounded: oldest goes

  // Keep coverage snapshots a quarter window apart, and only as far back as needed.
  if (snapshots_.empty() || hours - snapshots_.back().hours >= config_.change_window_h / 4) {
    snapshots_.push_back({hours, coverage});
  }
  while (snapshots_.size() > 2 && snapshots_[1].hours <= hours - config_.change_window_h) snapshots_.pop_front();

  const bool under = r.rel_change >= 0 && r.rel_change < config_.tolerance && r.rel_se >= 0 &&
                     r.rel_se < config_.tolerance && r.kl_growth >= 0 && r.kl_growth < config_.kl_threshold;
  if (under) {
    if (under_since_hours_ < 0) under_since_hours_ = hours;
    r.hours_under_tolerance = hours - under_since_hours_;
  } else {
    under_since_hours_ = -1;
  }
  const std::string moved =
      r.change_from_prior
          ? Fmt("EG moved %.2f %% from its priors' EG (the priors counted as %.2f h of driving, the last %.1f h reaching "
                "into them)", 100 * r.rel_change, prior.hours, config_.change_window_h)
          : Fmt("EG moved %.2f %% over the last %.1f h", 100 * r.rel_change, config_.change_window_h);
  if (r.rel_change < 0 || r.kl_growth < 0) {
    r.state = State::kCollecting;
    r.explanation = Fmt("%.2f gated h; need %.1f h of history before EG's change can be judged", hours,
                        config_.change_window_h);
    if (prior.hours > 0) r.explanation += Fmt(" (the priors count as %.2f h)", prior.hours);
  } else if (under && r.hours_under_tolerance >= config_.hold_h) {
    r.state = State::kAdequate;
    r.explanation = moved + Fmt(", relative standard error %.2f %%, coverage growth %.4f nats: all under tolerance for "
                                "%.1f h (hold %.1f h); more driving of this kind adds no information",
                                100 * r.rel_se, r.kl_growth, r.hours_under_tolerance, config_.hold_h);
  } else {
    r.state = State::kConverging;
    r.explanation = moved + Fmt(" (tolerance %.2f %%), relative standard error %.2f %%, coverage growth %.4f nats "
                                "(threshold %.4f); under tolerance for %.1f of %.1f h",
                                100 * config_.tolerance, 100 * r.rel_se, r.kl_growth, config_.kl_threshold,
                                r.hours_under_tolerance, config_.hold_h);
  }
  last_ = r;
  return r;
}

nlohmann::json Tracker::ToJson() const {
  nlohmann::json j;
  j["history"] = nlohmann::json::array();
  for (const EgPoint& p : history_)
    j["history"].push_back({{"gated_hours", p.gated_hours}, {"eg", p.eg}, {"eg_se", p.eg_se}, {"kl", p.kl}});
  j["snapshots"] = nlohmann::json::array();
  for (const Snapshot& s : snapshots_) j["snapshots"].push_back({{"hours", s.hours}, {"coverage", s.coverage.ToJson()}});
  j["under_since_hours"] = under_since_hours_;
  j["state"] = StateName(last_.state);
  return j;
}

void Tracker::FromJson(const JsonIn& in) {
  const JsonIn h = in.At("history");
  const size_t n = h.Size(kMaxHistoryPoints);
  std::vector<EgPoint> history(n);
  for (size_t i = 0; i < n; ++i) {
    const JsonIn p = h.At(i);
    history[i] = EgPoint{p.Finite("gated_hours"), p.Finite("eg"), p.Finite("eg_se"), p.Finite("kl")};
  }
  const JsonIn sn = in.At("snapshots");
  const size_t ns = sn.Size(kMaxSnapshots);
  std::deque<Snapshot> snaps;
  for (size_t i = 0; i < ns; ++i) {
    const JsonIn s = sn.At(i);
    snaps.push_back(Snapshot{s.Finite("hours"), stats::Coverage::FromJson(s.At("coverage"))});
  }
  const double under = in.Finite("under_since_hours");
  const State state = StateFromJson(in.At("state"));
  history_ = std::move(history);
  snapshots_ = std::move(snaps);
  under_since_hours_ = under;
  last_ = Report{};
  last_.state = state;
}

}  // namespace ndsid::adequacy
