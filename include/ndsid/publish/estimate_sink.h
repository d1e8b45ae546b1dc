// The output end of the pipeline: where estimates, status and the monitor stream go. Plain
// structs here (no LCM), so the daemon composes them without knowing the transport; the LCM
// publisher (lcm_publisher.h) is the implementation, tests may record them in memory.
#pragma once

#include <array>
#include <cstdint>
#include <string>
#include <vector>

namespace ndsid::publish {

struct ParameterValue {
  std::string name;  // m, Jz, cv, ch, lv, is
  std::string unit;
  double value = 0;
  double sigma = 0;  // standard error (0 when fixed)
  bool fixed = false;
  bool at_bound = false;
};

// Mirrors lcmtypes/ndsid_estimate_t.lcm field by field (see there for units).
struct EstimateMessage {
  int64_t utime = 0;
  int64_t publish_utime = 0;
  std::string vehicle;
  int32_t identifications = 0;
  bool valid = false;
  std::string reason;
  double eg_rad_per_mps2 = 0, eg_sigma_rad_per_mps2 = 0;
  double eg_deg_per_g = 0, eg_sigma_deg_per_g = 0;
  std::vector<ParameterValue> params;
  double rmse_train_mps2 = 0, rmse_validation_mps2 = -1;
  std::string se_method;
  double gated_hours = 0, window_hours = 0;
  int32_t training_segments = 0, validation_segments = 0;
  bool steady_state_valid = false;
  double steady_state_eg_rad_per_mps2 = 0, steady_state_eg_sigma_rad_per_mps2 = 0, steady_state_steer_ratio = 0;
  std::string adequacy_state;
  double adequacy_rel_change = -1, adequacy_rel_sigma = -1, adequacy_kl_growth = -1, adequacy_hours_under_tolerance = 0;
  std::string adequacy_explanation;
  std::vector<std::string> effects;
  struct CheckValue {
    std::string name, verdict;
    double value = 0;
    std::string message;
  };
  std::vector<CheckValue> checks;  // every check behind `valid`
};

// Mirrors lcmtypes/ndsid_status_t.lcm.
struct StatusMessage {
  int64_t utime = 0;
  int64_t publish_utime = 0;
  std::string vehicle;
  std::string source;
  std::string source_state;
  int64_t frames_read = 0, frames_decoded = 0, frames_unknown = 0, frames_too_short = 0;
  int64_t malformed = 0, bus_errors = 0, dropped = 0, reconnects = 0, time_backwards = 0;
  int64_t frames_skipped_resume = 0;
  std::vector<std::string> gate_reason;  // parallel to gate_count
  std::vector<int64_t> gate_count;
  int64_t drives = 0;
  double gated_hours = 0;
  int64_t standstill_samples = 0;
  double standstill_lat_accel_mps2 = 0;
  bool identification_running = false;
  double last_persist_age_s = -1;
};

// Mirrors lcmtypes/ndsid_monitor_t.lcm.
struct MonitorMessage {
  int64_t utime = 0;
  double lat_accel_mps2 = 0, lat_accel_model_mps2 = 0;
  double yaw_rate_radps = 0, yaw_rate_model_radps = 0;
  double speed_mps = 0, steer_rad = 0;
  bool model_valid = false;
  std::string verdict;
};

struct SinkCounters {
  uint64_t estimates = 0, statuses = 0, monitors = 0;  // sent
  uint64_t failures = 0;                               // sends the transport refused
};

// Never throws from Publish*: a failed send is counted (and logged, rate-limited), since the
// reading path must not stop because nobody listens.
class EstimateSink {
 public:
  virtual ~EstimateSink() = default;
  virtual void PublishEstimate(const EstimateMessage& m) noexcept = 0;
  virtual void PublishStatus(const StatusMessage& m) noexcept = 0;
  virtual void PublishMonitor(const MonitorMessage& m) noexcept = 0;
  virtual const SinkCounters& counters() const noexcept = 0;
};

}  // namespace ndsid::publish
