#include "ndsid/gate/gate.h"

#include <cmath>

namespace ndsid::gate {

namespace {
constexpr double kRateFilter_s = 0.2;  // low-pass time constant before differentiating
}  // namespace

const char* VerdictName(Verdict v) {
  switch (v) {
    case Verdict::kAccepted: return "accepted";
    case Verdict::kInvalidSignal: return "invalid_signal";
    case Verdict::kReverse: return "reverse";
    case Verdict::kEscIntervention: return "esc_intervention";
    case Verdict::kStandstill: return "standstill";
    case Verdict::kBelowMinSpeed: return "below_min_speed";
    case Verdict::kNonlinearRange: return "nonlinear_range";
    default: return "?";
  }
}

uint64_t GateCounters::samples() const {
  uint64_t n = 0;
  for (auto c : by_verdict) n += c;
  return n;
}

Gate::Gate(const config::GateConfig& config, double sample_period_s) : config_(config), period_s_(sample_period_s) {}

GatedSample Gate::Process(const sync::Sample& s) noexcept {
  GatedSample g;
  g.sample = s;
  const double gap_s = static_cast<double>(s.t_ns - last_t_ns_) * 1e-9;
  if (drive_id_ < 0 || gap_s > config_.drive_gap_s || gap_s < 0) {
    EndStop();
    // A key cycle ends at a bus silence longer than drive_gap_s (time going backwards: likewise).
    ++drive_id_;
    ++counters_.drives;
    g.new_drive = true;
    drive_distance_m_ = 0;
    slow_since_s_ = -1;
    have_prev_ = false;
    prev_accepted_ = false;
  }
  const bool contiguous = have_prev_ && !s.gap_before && gap_s < 2.5 * period_s_;
  const double dt = contiguous ? gap_s : period_s_;
  if (s.valid) drive_distance_m_ += std::max(0.0, s.speed_mps) * dt;
  g.drive_id = drive_id_;
  g.drive_distance_m = drive_distance_m_;
  if (contiguous && s.valid) {
    // Rates of low-passed signals (time constant kRateFilter_s): a raw backward difference of
    // a 0.1 deg-quantised angle at 100 Hz would be all quantisation noise.
    const double alpha = dt / (kRateFilter_s + dt);
    const double steer_f = prev_steer_ + alpha * (s.steer_rad - prev_steer_);
    const double yaw_f = prev_yaw_ + alpha * (s.yaw_rate_radps - prev_yaw_);
    g.steer_rate_radps = (steer_f - prev_steer_) / dt;
    g.yaw_accel_radps2 = s.has_yaw_rate ? (yaw_f - prev_yaw_) / dt : 0.0;
    prev_steer_ = steer_f;
    prev_yaw_ = yaw_f;
  } else if (s.valid) {
    prev_steer_ = s.steer_rad;
    prev_yaw_ = s.yaw_rate_radps;
  }

  // Standstill: slow for longer than standstill_min_s. Its a_y is the cross-slope diagnostic.
  bool standstill = false;
  if (s.valid && std::abs(s.speed_mps) < config_.standstill_speed_mps) {
    if (slow_since_s_ < 0) slow_since_s_ = s.t_s();
    standstill = s.t_s() - slow_since_s_ >= config_.standstill_min_s;
  } else {
    slow_since_s_ = -1;
  }

  if (!s.valid) {
    g.verdict = Verdict::kInvalidSignal;
  } else if (s.reverse) {
    g.verdict = Verdict::kReverse;
  } else if (s.esc_active) {
    g.verdict = Verdict::kEscIntervention;
  } else if (standstill) {
    g.verdict = Verdict::kStandstill;
    ++standstill_.samples;
    standstill_.sum_lat_accel += s.lat_accel_mps2;
    standstill_.sum_sq_lat_accel += s.lat_accel_mps2 * s.lat_accel_mps2;
    if (stop_.samples == 0) {
      stop_.drive_id = drive_id_;
      stop_.t_start_ns = s.t_ns;
    }
    ++stop_.samples;
    stop_sum_a_ += s.lat_accel_mps2;
    if (s.has_yaw_rate && std::isfinite(s.yaw_rate_radps)) {
      ++stop_samples_r_;
      stop_sum_r_ += s.yaw_rate_radps;
    }
    stop_last_ns_ = s.t_ns;
  } else if (s.speed_mps <= config_.min_speed_mps) {
    g.verdict = Verdict::kBelowMinSpeed;
  } else if (std::abs(s.lat_accel_mps2) >= config_.max_abs_lat_accel_mps2) {
    g.verdict = Verdict::kNonlinearRange;
  }
  if (g.verdict != Verdict::kStandstill && s.valid) EndStop();  // moving again (an invalid sample does not end it)
  const bool accepted = g.verdict == Verdict::kAccepted;
  g.segment_start = accepted && (!prev_accepted_ || !contiguous);
  g.quasi_steady = accepted && contiguous && std::abs(g.steer_rate_radps) < config_.quasi_steady_max_steer_rate_radps &&
                   (!s.has_yaw_rate || std::abs(g.yaw_accel_radps2) < config_.quasi_steady_max_yaw_accel_radps2);
  ++counters_.by_verdict[static_cast<int>(g.verdict)];

  prev_accepted_ = accepted;
  have_prev_ = s.valid;
  last_t_ns_ = s.t_ns;
  return g;
}

void Gate::EndStop() noexcept {
  if (stop_.samples == 0) return;
  stop_.seconds = static_cast<double>(stop_last_ns_ - stop_.t_start_ns) * 1e-9 + period_s_;
  stop_.mean_lat_accel_mps2 = stop_sum_a_ / static_cast<double>(stop_.samples);
  stop_.mean_yaw_rate_radps = stop_samples_r_ > 0 ? stop_sum_r_ / static_cast<double>(stop_samples_r_)
                                                  : std::numeric_limits<double>::quiet_NaN();
  // Bounded: the identification's window holds the stops of its drives; a daemon that is never
  // asked keeps the newest kMaxStops.
  constexpr size_t kMaxStops = 100000;
  if (stops_.size() >= kMaxStops) stops_.erase(stops_.begin(), stops_.begin() + kMaxStops / 2);
  try {
    stops_.push_back(stop_);
  } catch (...) {  // out of memory: the stop is lost, nothing else
  }
  stop_ = StandstillStop{};
  stop_sum_a_ = stop_sum_r_ = 0;
  stop_samples_r_ = 0;
}

void Gate::Finish() noexcept { EndStop(); }

std::vector<StandstillStop> Gate::TakeStops() {
  std::vector<StandstillStop> out;
  out.swap(stops_);
  return out;
}

}  // namespace ndsid::gate
