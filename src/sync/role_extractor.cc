#include "ndsid/sync/role_extractor.h"

#include <algorithm>
#include <cmath>

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
    if (!role) continue;
    if (role->expression) {
      for (const auto& in : role->inputs) add(in);
    } else {
      add(role->ref);
    }
  }
  for (const auto& v : c.validity) add(v.ref);
  return sel;
}

}  // namespace

static_assert(config::kNumRoles <= 32, "one bit per role in Process()");

RoleExtractor::RoleExtractor(const config::Config& config, const dbc::Database& db)
    : config_(config), decoder_((config::ValidateAgainstDbc(config, db), db), Selection(config)) {
  targets_.resize(decoder_.signals().size());
  expr_inputs_.resize(config::kNumRoles);
  for (int i = 0; i < config::kNumRoles; ++i) {
    if (!config.roles[i]) continue;
    if (config.roles[i]->expression) {
      const auto& inputs = config.roles[i]->inputs;
      expr_inputs_[i].resize(inputs.size());
      expr_values_.resize(std::max(expr_values_.size(), inputs.size()));
      for (size_t k = 0; k < inputs.size(); ++k) {
        const int idx = decoder_.SignalIndex(inputs[k].message, inputs[k].signal);
        if (idx >= 0) targets_[idx].push_back({i, -1, static_cast<int>(k), inputs[k].message == inputs[0].message});
      }
      continue;
    }
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
  uint32_t touched = 0;  // expression roles whose time-base message this frame is (bit per role)
  for (size_t k = 0; k < n; ++k) {
    const dbc::DecodedValue& dv = scratch_[k];
    for (const Target& t : targets_[dv.signal_index]) {
      if (t.input >= 0) {
        expr_inputs_[t.role][t.input] = {dv.value, frame.timestamp_ns, true};
        if (t.clock) touched |= 1u << t.role;
      } else if (t.role >= 0) {
        const auto role = static_cast<config::Role>(t.role);
        const double v = config::RoleIsFlag(role) ? dv.value : config_.roles[t.role]->ToSi(dv.value);
        sync.PushRole(role, frame.timestamp_ns, v);
      } else {
        sync.PushValidity(static_cast<size_t>(t.validity), frame.timestamp_ns, dv.value);
      }
    }
  }
  for (int role = 0; touched != 0; ++role, touched >>= 1) {
    if (touched & 1u) EvaluateExpression(role, frame.timestamp_ns, sync);
  }
}

// A role expression is evaluated when a frame of its time-base message (the message of its first
// input) arrives, from the latest value of each input; so a value carries the time of the frame
// that set it, and a slower message's input is sampled and held. Not evaluated while an input is
// missing or older than the role's timeout_s (its value would mix times), and not when the result
// is not finite (a division by zero on the bus: no value, the sync stage's staleness rule takes
// over).
void RoleExtractor::EvaluateExpression(int role, int64_t t_ns, SignalSync& sync) noexcept {
  const config::RoleSignal& r = *config_.roles[role];
  const auto& inputs = expr_inputs_[role];
  const auto timeout_ns = static_cast<int64_t>(r.timeout_s * 1e9);
  for (size_t k = 0; k < inputs.size(); ++k) {
    if (!inputs[k].seen || t_ns - inputs[k].t_ns > timeout_ns) return;
    expr_values_[k] = inputs[k].value;
  }
  const double physical = r.expression->Evaluate(expr_values_.data());
  if (!std::isfinite(physical)) return;
  const auto which = static_cast<config::Role>(role);
  sync.PushRole(which, t_ns, config::RoleIsFlag(which) ? physical : r.ToSi(physical));
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
