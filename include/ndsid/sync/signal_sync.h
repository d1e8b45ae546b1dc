// Role signals arrive at different rates and phases; SignalSync resamples them onto a fixed
// grid (default 100 Hz) by linear interpolation (flags: last value), marking a sample invalid
// when a required role is older than its timeout. Driven only by data timestamps. A role with
// a configured latency (signals.<role>.latency_s) is read at t_bus - latency: time alignment. A
// role with signals.<role>.lowpass_hz is filtered on the grid (lowpass.h) and read the filter's
// delay later, so it stays aligned; the filter restarts after a gap or a stale stretch.
#pragma once

#include <array>
#include <cstdint>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/sync/lowpass.h"
#include "ndsid/sync/sample.h"

namespace ndsid::sync {

struct SyncCounters {
  uint64_t values = 0;            // role / validity values pushed
  uint64_t time_backwards = 0;    // values older than the previous value of the same signal (dropped)
  uint64_t non_finite = 0;        // NaN / inf values (dropped)
  uint64_t samples = 0;           // samples emitted
  uint64_t invalid_samples = 0;   // samples emitted with valid == false
  uint64_t gaps = 0;              // bus silences not filled
};

class SignalSync {
 public:
  explicit SignalSync(const config::Config& config);

  // Values in SI. Dropped (and counted) when not finite or older than the previous one.
  void PushRole(config::Role role, int64_t t_ns, double value_si) noexcept;
  void PushValidity(size_t index, int64_t t_ns, double physical) noexcept;

  // Emits (appends to `out`) every grid sample at or before now_ns - latency, and not past the
  // newest value of a role still within its timeout (a slow role is waited for, not held).
  void Advance(int64_t now_ns, std::vector<Sample>& out) noexcept;
  // End of stream: emits the samples up to the last value seen.
  void Flush(std::vector<Sample>& out) noexcept;

  const SyncCounters& counters() const noexcept { return counters_; }
  // The mean interval between a role's values [s] (bus silences longer than max_fill_gap_s left
  // out); 0 before its second value.
  double MeanInterval_s(config::Role role) const noexcept;
  int64_t period_ns() const noexcept { return period_ns_; }

 private:
  static constexpr int kHistory = 128;  // values kept per role: a wait for a slow role reads back
  struct Point {
    int64_t t_ns;
    double value;
  };
  struct Channel {
    std::array<Point, kHistory> ring{};
    int size = 0;
    int head = 0;  // index of the newest
    int64_t timeout_ns = 0;
    int64_t shift_ns = 0;  // signals.<role>.latency_s: values are stored at t_bus - shift
    BesselLowPass filter;  // signals.<role>.lowpass_hz (disabled: none)
    int64_t lead_ns = 0;   // the filter's delay: grid sample t is filtered from the value at t + lead
    int64_t interval_sum_ns = 0;  // intervals between values (MeanInterval_s)
    uint64_t intervals = 0;
    const Point& newest() const { return ring[head]; }
    const Point& at(int age) const { return ring[(head - age + kHistory) % kHistory]; }
    void Push(Point p);
  };
  bool Interpolate(const Channel& c, int64_t t, double& value) const noexcept;
  bool Hold(const Channel& c, int64_t t, double& value) const noexcept;
  void EmitUntil(int64_t t_end, std::vector<Sample>& out) noexcept;
  int64_t ReadyUntil(int64_t now_ns) const noexcept;
  void Note(int64_t t_ns, std::vector<Sample>* out) noexcept;
  bool AcceptTime(Channel& c, int64_t t_ns, double v) noexcept;

  const config::Config& config_;
  std::array<Channel, config::kNumRoles> roles_{};
  std::vector<Channel> validity_;
  std::vector<std::vector<double>> validity_values_;
  int64_t period_ns_;
  int64_t latency_ns_;
  int64_t max_gap_ns_;
  int64_t next_t_ns_ = 0;      // next grid instant to emit
  int64_t last_seen_ns_ = 0;   // newest value time
  bool started_ = false;
  bool pending_gap_ = false;
  SyncCounters counters_;
};

}  // namespace ndsid::sync
