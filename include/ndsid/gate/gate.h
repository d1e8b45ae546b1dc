// Which synchronised samples may enter identification, and why the others may not.
// Also segments the stream into drives (key cycles: gaps on the bus) and contiguous gated
// stretches, and keeps the standstill lateral acceleration as the road cross-slope diagnostic.
#pragma once

#include <array>
#include <cstdint>
#include <limits>
#include <string>
#include <vector>

#include "ndsid/config/config.h"
#include "ndsid/sync/sample.h"

namespace ndsid::gate {

enum class Verdict : uint8_t {
  kAccepted = 0,
  kInvalidSignal,    // a required role stale / missing, or a validity flag said invalid
  kReverse,          // reverse gear
  kEscIntervention,  // ESC / ABS intervening
  kStandstill,       // v < standstill speed for longer than standstill_min_s
  kBelowMinSpeed,    // v <= min_speed (model singular at v -> 0)
  kNonlinearRange,   // |a_y| >= linear-range limit
  kCount
};
inline constexpr int kNumVerdicts = static_cast<int>(Verdict::kCount);
const char* VerdictName(Verdict v);

struct GatedSample {
  sync::Sample sample;
  Verdict verdict = Verdict::kAccepted;
  int64_t drive_id = 0;              // key-cycle counter
  bool new_drive = false;            // first sample of a drive
  bool segment_start = false;        // first accepted sample after a rejected one (or a new drive)
  bool quasi_steady = false;         // low steering rate and yaw acceleration: steady-state regression
  double steer_rate_radps = 0;       // d_sw' by backward difference
  double yaw_accel_radps2 = 0;       // r' (0 when no yaw rate)
  double drive_distance_m = 0;       // distance driven in this drive so far
};

// Diagnostic: mean lateral acceleration at standstill = g*sin(cross-slope) (never subtracted).
struct StandstillDiagnostic {
  uint64_t samples = 0;
  double sum_lat_accel = 0;
  double sum_sq_lat_accel = 0;
  double mean_mps2() const { return samples ? sum_lat_accel / samples : 0.0; }
};

// One standstill (slow for at least standstill_min_s, until the car moves or the drive ends):
// the means of the measured a_y and yaw rate over it. There a_y = accelerometer bias +
// g sin(cross-slope) and the yaw rate = the gyro offset: the evidence the identification uses for
// accel_bias and gyro_offset (docs/two-outputs.md, "Standstill evidence").
struct StandstillStop {
  int64_t drive_id = 0;
  int64_t t_start_ns = 0;
  double seconds = 0;
  uint64_t samples = 0;
  double mean_lat_accel_mps2 = 0;
  double mean_yaw_rate_radps = std::numeric_limits<double>::quiet_NaN();  // NaN: no yaw rate
};

struct GateCounters {
  std::array<uint64_t, kNumVerdicts> by_verdict{};
  uint64_t drives = 0;
  uint64_t samples() const;
};

class Gate {
 public:
  explicit Gate(const config::GateConfig& config, double sample_period_s);
  GatedSample Process(const sync::Sample& sample) noexcept;

  const GateCounters& counters() const noexcept { return counters_; }
  const StandstillDiagnostic& standstill() const noexcept { return standstill_; }
  // Standstills completed since the last call (a stop ends when the car moves, the drive
  // ends, or Finish() is called), moved out.
  std::vector<StandstillStop> TakeStops();
  void Finish() noexcept;  // end of data: completes the standstill in progress

 private:
  config::GateConfig config_;
  double period_s_;
  GateCounters counters_;
  StandstillDiagnostic standstill_;
  void EndStop() noexcept;
  StandstillStop stop_;            // the standstill in progress (samples 0: none)
  double stop_sum_a_ = 0, stop_sum_r_ = 0;
  uint64_t stop_samples_r_ = 0;
  int64_t stop_last_ns_ = 0;
  std::vector<StandstillStop> stops_;  // completed, not yet taken
  int64_t drive_id_ = -1;
  int64_t last_t_ns_ = 0;
  double drive_distance_m_ = 0;
  double slow_since_s_ = -1;  // time the speed first fell below standstill speed, -1 if moving
  bool prev_accepted_ = false;
  bool have_prev_ = false;
  double prev_steer_ = 0, prev_yaw_ = 0;
};

}  // namespace ndsid::gate
