#include "ndsid/sync/signal_sync.h"

#include <algorithm>
#include <cmath>
#include <cstdint>

namespace ndsid::sync {

using config::Role;

void SignalSync::Channel::Push(Point p) {
  head = (head + 1) % kHistory;
  ring[head] = p;
  if (size < kHistory) ++size;
}

SignalSync::SignalSync(const config::Config& config)
    : config_(config),
      period_ns_(static_cast<int64_t>(std::llround(1e9 / config.sync.rate_hz))),
      latency_ns_(static_cast<int64_t>(std::llround(config.sync.latency_s * 1e9))),
      max_gap_ns_(static_cast<int64_t>(std::llround(config.sync.max_fill_gap_s * 1e9))) {
  int64_t max_shift_ns = 0;
  for (int i = 0; i < config::kNumRoles; ++i) {
    if (!config.roles[i]) continue;
    roles_[i].timeout_ns = static_cast<int64_t>(std::llround(config.roles[i]->timeout_s * 1e9));
    roles_[i].shift_ns = static_cast<int64_t>(std::llround(config.roles[i]->latency_s * 1e9));
    if (config.roles[i]->lowpass_hz > 0 && !config::RoleIsFlag(static_cast<Role>(i))) {
      roles_[i].filter = BesselLowPass(config.roles[i]->lowpass_hz, config.sync.rate_hz);
      roles_[i].lead_ns = static_cast<int64_t>(std::llround(roles_[i].filter.delay_s() * 1e9));
    }
    max_shift_ns = std::max(max_shift_ns, roles_[i].shift_ns + roles_[i].lead_ns);
  }
  // A role read at t - latency arrives that much later: wait for it before emitting.
  latency_ns_ += max_shift_ns;
  validity_.resize(config.validity.size());
  for (size_t i = 0; i < config.validity.size(); ++i) {
    validity_[i].timeout_ns = static_cast<int64_t>(std::llround(config.validity[i].timeout_s * 1e9));
  }
}

bool SignalSync::AcceptTime(Channel& c, int64_t t_ns, double v) noexcept {
  ++counters_.values;
  if (!std::isfinite(v)) {
    ++counters_.non_finite;
    return false;
  }
  if (c.size > 0 && t_ns < c.newest().t_ns) {
    ++counters_.time_backwards;
    return false;
  }
  if (!started_) {
    started_ = true;
    next_t_ns_ = (t_ns / period_ns_ + 1) * period_ns_;
  }
  if (t_ns > last_seen_ns_) last_seen_ns_ = t_ns;
  return true;
}

void SignalSync::PushRole(Role role, int64_t t_ns, double value_si) noexcept {
  Channel& c = roles_[static_cast<int>(role)];
  t_ns -= c.shift_ns;  // time alignment: the instant the value describes
  if (!AcceptTime(c, t_ns, value_si)) return;
  if (c.size > 0) {  // the interval since the role's previous value, bus silences left out
    const int64_t d = t_ns - c.newest().t_ns;
    if (d > 0 && d <= max_gap_ns_) c.interval_sum_ns += d, ++c.intervals;
  }
  c.Push({t_ns, value_si});
}

double SignalSync::MeanInterval_s(Role role) const noexcept {
  const Channel& c = roles_[static_cast<int>(role)];
  return c.intervals ? 1e-9 * static_cast<double>(c.interval_sum_ns) / static_cast<double>(c.intervals) : 0.0;
}

void SignalSync::PushValidity(size_t index, int64_t t_ns, double physical) noexcept {
  if (index >= validity_.size()) return;
  Channel& c = validity_[index];
  if (AcceptTime(c, t_ns, physical)) c.Push({t_ns, physical});
}

// Linear interpolation between the two values bracketing t, unless they are further apart
// than the fill gap (then the older one is held, within its timeout).
bool SignalSync::Interpolate(const Channel& c, int64_t t, double& value) const noexcept {
  for (int age = 0; age < c.size; ++age) {
    const Point& a = c.at(age);
    if (a.t_ns > t) continue;
    if (age > 0) {
      const Point& b = c.at(age - 1);
      if (b.t_ns - a.t_ns <= max_gap_ns_ && b.t_ns > a.t_ns) {
        const double w = static_cast<double>(t - a.t_ns) / static_cast<double>(b.t_ns - a.t_ns);
        value = a.value + w * (b.value - a.value);
        return t - a.t_ns <= c.timeout_ns || b.t_ns - t <= c.timeout_ns;
      }
    }
    value = a.value;
    return t - a.t_ns <= c.timeout_ns;
  }
  return false;
}

bool SignalSync::Hold(const Channel& c, int64_t t, double& value) const noexcept {
  for (int age = 0; age < c.size; ++age) {
    const Point& a = c.at(age);
    if (a.t_ns > t) continue;
    value = a.value;
    return t - a.t_ns <= c.timeout_ns;
  }
  return false;
}

void SignalSync::EmitUntil(int64_t t_end, std::vector<Sample>& out) noexcept {
  while (started_ && next_t_ns_ <= t_end) {
    const int64_t t = next_t_ns_;
    next_t_ns_ += period_ns_;
    Sample s;
    s.t_ns = t;
    s.gap_before = pending_gap_;
    if (pending_gap_)
      for (Channel& c : roles_) c.filter.Reset();
    pending_gap_ = false;
    double v = 0;
    for (int i = 0; i < config::kNumRoles; ++i) {
      const Role role = static_cast<Role>(i);
      const auto& spec = config_.roles[i];
      if (!spec) continue;
      Channel& channel = roles_[i];
      const bool fresh = config::RoleIsFlag(role) ? Hold(channel, t, v) : Interpolate(channel, t + channel.lead_ns, v);
      if (!fresh) {
        channel.filter.Reset();
        s.stale_roles |= static_cast<uint16_t>(1u << i);
        continue;
      }
      v = channel.filter.Step(v);
      switch (role) {
        case Role::kSteeringWheelAngle: s.steer_rad = v; break;
        case Role::kSpeed: s.speed_mps = v; break;
        case Role::kLateralAcceleration: s.lat_accel_mps2 = v; break;
        case Role::kYawRate: s.yaw_rate_radps = v; s.has_yaw_rate = true; break;
        case Role::kLongitudinalAcceleration: s.long_accel_mps2 = v; s.has_long_accel = true; break;
        case Role::kReverseGear: s.reverse = spec->IsActive(v); break;
        case Role::kEscIntervention: s.esc_active = spec->IsActive(v); break;
        case Role::kWheelSpeed: s.wheel_speed_mps = v; s.has_wheel_speed = true; break;
        case Role::kRearWheelSpeedDifference: s.rear_wheel_diff_mps = v; s.has_rear_wheel_diff = true; break;
        default: break;
      }
    }
    for (size_t i = 0; i < validity_.size(); ++i) {
      if (!Hold(validity_[i], t, v)) {
        s.flags_invalid = true;
        continue;
      }
      bool ok = false;
      for (double good : config_.validity[i].valid_values) ok = ok || std::abs(good - v) < 1e-9;
      if (!ok) s.flags_invalid = true;
    }
    bool required_fresh = true;
    for (int i = 0; i < config::kNumRoles; ++i) {
      if (config::RoleIsRequired(static_cast<Role>(i)) && (s.stale_roles & (1u << i))) required_fresh = false;
    }
    s.valid = required_fresh && !s.flags_invalid;
    ++counters_.samples;
    if (!s.valid) ++counters_.invalid_samples;
    out.push_back(s);
  }
}

void SignalSync::Advance(int64_t now_ns, std::vector<Sample>& out) noexcept {
  if (!started_) return;
  if (now_ns - last_seen_ns_ > max_gap_ns_) {
    // A bus silence: finish the stretch before it, then restart the grid after it.
    EmitUntil(last_seen_ns_, out);
    next_t_ns_ = (now_ns / period_ns_ + 1) * period_ns_;
    pending_gap_ = true;
    ++counters_.gaps;
    return;
  }
  EmitUntil(ReadyUntil(now_ns), out);
}

// The grid instant up to which every role can interpolate: now - latency, or earlier where a
// live role's newest value (stamped at most its timeout ago) does not yet reach past the instant
// it is read at. A slow or irregular role (a 12.5 Hz IMU message, lost frames) is then waited
// for, within its timeout, instead of held at its older value (a lag of up to a cycle).
// The wait never outlasts a role's history: a grid instant older than the oldest value a full
// ring still holds could no longer be interpolated, so such instants are emitted regardless.
int64_t SignalSync::ReadyUntil(int64_t now_ns) const noexcept {
  const int64_t latest = now_ns - latency_ns_;
  int64_t t_end = latest, history = INT64_MIN;
  for (int i = 0; i < config::kNumRoles; ++i) {
    const Channel& c = roles_[i];
    if (!config_.roles[i] || c.size == 0) continue;
    if (c.size == kHistory) history = std::max(history, c.at(kHistory - 1).t_ns - c.lead_ns);
    if (config::RoleIsFlag(static_cast<Role>(i))) continue;
    const int64_t newest = c.newest().t_ns;
    if (now_ns - c.shift_ns - newest <= c.timeout_ns) t_end = std::min(t_end, newest - c.lead_ns);
  }
  return std::min(latest, std::max(t_end, history));
}

void SignalSync::Flush(std::vector<Sample>& out) noexcept { EmitUntil(last_seen_ns_, out); }

}  // namespace ndsid::sync
