#include "ndsid/stats/accumulator.h"

#include <algorithm>
#include <cmath>

namespace ndsid::stats {

Accumulator::Accumulator(const config::Config& config, double sync_rate_hz)
    : config_(config),
      decimation_(std::max(1, static_cast<int>(std::lround(sync_rate_hz / config.identification.rate_hz)))),
      segment_dt_s_(decimation_ / sync_rate_hz),
      min_segment_samples_(static_cast<size_t>(std::ceil(config.gate.min_segment_s / (decimation_ / sync_rate_hz)))),
      window_s_(config.identification.window_h * 3600.0) {}

void Accumulator::Add(const gate::GatedSample& g) {
  if (g.new_drive) {
    CloseSegment();
    CloseDrive();
    drives_.push_back({g.drive_id, g.sample.t_ns, g.sample.t_ns, 0, 0, false});
    drive_open_ = true;
    drive_used_ = false;
  }
  if (!drive_open_) {
    drives_.push_back({g.drive_id, g.sample.t_ns, g.sample.t_ns, 0, 0, false});
    drive_open_ = true;
  }
  DriveSummary& d = drives_.back();
  d.end_ns = g.sample.t_ns;
  d.distance_km = g.drive_distance_m / 1000.0;

  const bool accepted = g.verdict == gate::Verdict::kAccepted;
  if (!accepted || g.segment_start) CloseSegment();
  if (accepted) {
    const double period = segment_dt_s_ / decimation_;
    d.gated_s += period;
    (drive_used_ ? steady_ : pending_steady_).Add(g);
    (drive_used_ ? coverage_ : pending_coverage_).Add(g);
    if (drive_used_) {
      gated_s_ += period;
    } else {
      pending_gated_s_ += period;
      ++pending_samples_;
    }
    // Decimate by averaging `decimation_` consecutive samples (a boxcar anti-alias filter).
    if (!segment_open_) {
      current_ = Segment{};
      current_.drive_id = g.drive_id;
      current_.dt_s = segment_dt_s_;
      current_.has_yaw_rate = g.sample.has_yaw_rate;
      current_.has_long_accel = g.sample.has_long_accel;
      segment_open_ = true;
      summed_ = 0;
    }
    if (summed_ == 0) {
      sum_ = SegmentSample{};
      sum_t0_ns_ = g.sample.t_ns;
    }
    const auto& s = g.sample;
    sum_.steer_rad += static_cast<float>(s.steer_rad);
    sum_.speed_mps += static_cast<float>(s.speed_mps);
    sum_.lat_accel_mps2 += static_cast<float>(s.lat_accel_mps2);
    sum_.yaw_rate_radps += static_cast<float>(s.yaw_rate_radps);
    sum_.long_accel_mps2 += static_cast<float>(s.long_accel_mps2);
    current_.has_yaw_rate = current_.has_yaw_rate && s.has_yaw_rate;
    current_.has_long_accel = current_.has_long_accel && s.has_long_accel;
    if (++summed_ == decimation_) {
      const float k = 1.0f / static_cast<float>(decimation_);
      if (current_.samples.empty()) current_.t0_ns = sum_t0_ns_;
      current_.samples.push_back({sum_.steer_rad * k, sum_.speed_mps * k, sum_.lat_accel_mps2 * k,
                                  sum_.yaw_rate_radps * k, sum_.long_accel_mps2 * k});
      summed_ = 0;
    }
  }
  if (!drive_used_ && d.distance_km >= config_.gate.min_drive_km) CommitPending();
}

void Accumulator::CommitPending() {
  drive_used_ = true;
  if (!drives_.empty()) drives_.back().used = true;
  steady_.Merge(pending_steady_);
  coverage_.Merge(pending_coverage_);
  pending_steady_ = SteadyStateStats{};
  pending_coverage_ = Coverage{};
  gated_s_ += pending_gated_s_;
  pending_gated_s_ = 0;
  pending_samples_ = 0;
  for (auto& s : pending_segments_) window_.push_back(std::move(s));
  pending_segments_.clear();
}

void Accumulator::CloseSegment() {
  if (!segment_open_) return;
  segment_open_ = false;
  summed_ = 0;
  if (current_.samples.size() < min_segment_samples_) {
    counters_.short_segment_samples += current_.samples.size() * static_cast<uint64_t>(decimation_);
    return;
  }
  auto seg = std::make_shared<const Segment>(std::move(current_));
  if (drive_used_) {
    window_.push_back(std::move(seg));
  } else {
    pending_segments_.push_back(std::move(seg));
  }
  // Evict the oldest segments beyond the window (by accepted duration).
  double total = window_hours() * 3600.0;
  while (!window_.empty() && total - window_.front()->duration_s() >= window_s_) {
    total -= window_.front()->duration_s();
    window_.pop_front();
    ++counters_.evicted_segments;
  }
}

void Accumulator::CloseDrive() {
  if (!drive_open_) return;
  if (!drive_used_) {
    counters_.short_drive_samples += pending_samples_;
    pending_steady_ = SteadyStateStats{};
    pending_coverage_ = Coverage{};
    pending_segments_.clear();
    pending_gated_s_ = 0;
    pending_samples_ = 0;
  }
  drive_open_ = false;
  drive_used_ = false;
}

void Accumulator::Finish() {
  CloseSegment();
  CloseDrive();
}

double Accumulator::window_hours() const {
  double s = 0;
  for (const auto& seg : window_) s += seg->duration_s();
  return s / 3600.0;
}

}  // namespace ndsid::stats
