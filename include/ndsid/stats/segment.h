// A contiguous stretch of gated samples, decimated to the identification rate: the unit the
// output-error fit simulates independently from its inputs.
#pragma once

#include <cstdint>
#include <vector>

namespace ndsid::stats {

struct SegmentSample {
  float steer_rad;
  float speed_mps;
  float lat_accel_mps2;
  float yaw_rate_radps;
  float long_accel_mps2;
  float rear_wheel_diff_mps = 0;  // rear right minus rear left wheel speed (Segment::has_rear_wheel_diff)
};

struct Segment {
  int64_t t0_ns = 0;      // time of the first sample
  int64_t drive_id = 0;   // key cycle it belongs to
  double dt_s = 0.02;     // sample period
  bool has_yaw_rate = false;
  bool has_long_accel = false;
  bool has_rear_wheel_diff = false;
  std::vector<SegmentSample> samples;

  double duration_s() const { return dt_s * static_cast<double>(samples.size()); }
};

}  // namespace ndsid::stats
