#include "ndsid/sync/role_extractor.h"

#include <algorithm>

namespace ndsid::sync {
namespace {

std::vector<dbc::SignalSelector> Selection(const config::Config& c) {
  std::vector<dbc::SignalSelector> sel;
  auto add = [&](const config::SignalRef& r) {
    for (const auto& s : sel) {
      if (s.message == r.message && s.signal == r.signal) return;
    }
    sel.push_back({r.message, r.signal});
  };
  for (const auto& role : c.roles) {
    if (role) add(role->ref);
  }
  for (const auto& v : c.validity) add(v.ref);
  return sel;
}

}  // namespace

RoleExtractor::RoleExtractor(const config::Config& config, const dbc::Database& db)
    : config_(config), decoder_((config::ValidateAgainstDbc(config, db), db), Selection(config)) {
  targets_.resize(decoder_.signals().size());
  for (int i = 0; i < config::kNumRoles; ++i) {
    if (!config.roles[i]) continue;
    const int idx = decoder_.SignalIndex(config.roles[i]->ref.message, config.roles[i]->ref.signal);
    if (idx >= 0) targets_[idx].push_back({i, -1});
  }
  for (size_t i = 0; i < config.validity.size(); ++i) {
    const int idx = decoder_.SignalIndex(config.validity[i].ref.message, config.validity[i].ref.signal);
    if (idx >= 0) targets_[idx].push_back({-1, static_cast<int>(i)});
  }
  scratch_.resize(std::max<size_t>(decoder_.max_signals_per_message(), 1));
  if (config.source.bus.empty()) wanted_bus_ = -1;
}

void RoleExtractor::Process(const can::CanFrame& frame, const std::vector<std::string>& bus_names,
                            SignalSync& sync) noexcept {
  ++counters_.frames;
  if (frame.error()) {
    ++counters_.error_frames;
    return;
  }
  if (wanted_bus_ == -2 || (wanted_bus_ < 0 && !config_.source.bus.empty())) {
    // Resolve the configured bus name lazily: the source learns names as it reads.
    wanted_bus_ = -2;
    for (size_t i = 0; i < bus_names.size(); ++i) {
      if (bus_names[i] == config_.source.bus) wanted_bus_ = static_cast<int>(i);
    }
    if (wanted_bus_ == -2) {
      ++counters_.other_bus;
      return;
    }
  }
  if (wanted_bus_ >= 0 && frame.bus != wanted_bus_) {
    ++counters_.other_bus;
    return;
  }
  size_t n = 0;
  const dbc::DecodeVerdict verdict = decoder_.Decode(frame, scratch_, n);
  if (verdict == dbc::DecodeVerdict::kUnknownId || verdict == dbc::DecodeVerdict::kNotData) {
    ++counters_.unknown_id;
    return;
  }
  if (verdict == dbc::DecodeVerdict::kTooShort) ++counters_.too_short;
  if (n > 0) ++counters_.used;
  for (size_t k = 0; k < n; ++k) {
    const dbc::DecodedValue& dv = scratch_[k];
    for (const Target& t : targets_[dv.signal_index]) {
      if (t.role >= 0) {
        const auto role = static_cast<config::Role>(t.role);
        const double v = config::RoleIsFlag(role) ? dv.value : config_.roles[t.role]->ToSi(dv.value);
        sync.PushRole(role, frame.timestamp_ns, v);
      } else {
        sync.PushValidity(static_cast<size_t>(t.validity), frame.timestamp_ns, dv.value);
      }
    }
  }
}

std::vector<RoleExtractor::Id> RoleExtractor::NeededIds() const {
  std::vector<Id> ids;
  for (const auto& s : decoder_.signals()) {
    const Id id{s.message->id, s.message->extended};
    if (std::none_of(ids.begin(), ids.end(), [&](const Id& x) { return x.id == id.id && x.extended == id.extended; })) {
      ids.push_back(id);
    }
  }
  return ids;
}

}  // namespace ndsid::sync
