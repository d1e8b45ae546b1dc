// The yaw-rate sensor's scale against the rear wheel speeds (docs/two-outputs.md, "A yaw
// reference from the rear wheels"): model-free evidence that separates a gyro scale from an
// accelerometer scale, which a_y against v r cannot (its gain is biased by beta' and carries
// both). Two points of a rigid body a track width t apart across the rear axle move
// longitudinally at speeds differing by r t, whatever the sideslip, so with the rear wheels
// unsteered
//   v_RR - v_RL = (1 + eps) (r t + delta v + kappa a_y v)
// where eps is the wheel speeds' scale, delta the two tyres' rolling-radius difference and
// kappa the rolling radius's fall with lateral load (the outer wheel rolls on a smaller radius).
// With r_meas = (1 + k_r) r + r0, per 0.5 s block:
//   r_meas = s (v_RR - v_RL)/t + b2 v/t + b3 a_y v/t + per-chunk constant,   s = (1 + k_r)/(1 + eps)
// fitted by instrumental variables (instruments a_y/v, v/t, a_y v/t): the wheel speeds' noise is
// in the first regressor and would attenuate an ordinary least-squares slope; a_y/v follows r and
// is independent of both sensors' noise (a_y's own noise, averaged over the block, is small
// against its signal in the load term). Chunks (30 s) are demeaned (the gyro offset and slowly
// varying radius differences) and cluster the standard error. Blocks with wheel slip are left
// out: low speed, strong longitudinal or lateral acceleration (options below).
// What it measures is the gyro's scale relative to the rear wheel speeds' mean scale (a rear
// tyre whose rolling radius is d above the other's moves that mean by about -d/2): with the
// speed's scale (the vehicle speed is usually computed from the wheel speeds) from a_x against
// dv/dt (stats/speed_scale.h), k_r itself.
#pragma once

#include <string>
#include <vector>

#include "ndsid/stats/segment.h"

namespace ndsid::stats {

struct WheelYawOptions {
  double block_s = 0.5;            // samples averaged into one regression row
  double chunk_s = 30.0;           // demeaning and clustering unit
  int min_chunks = 10;             // fewer: no evidence
  double min_speed_mps = 5.0;      // below: parking manoeuvres, wheel-speed sensors' resolution
  double max_lat_accel_mps2 = 5.0;   // above: tyre slip and load transfer beyond the linear terms
  double max_long_accel_mps2 = 1.5;  // above: drive or brake slip differs between the rear wheels
  double min_yaw_sd_radps = 0.015;  // a chunk's yaw-rate variation below this (about 0.9 deg/s) carries no scale
  double max_abs_scale = 0.2;      // |s - 1| above: the difference's sign, unit or the track is wrong; no evidence
  // The data-sheet track width, and where the tyres' contact lines lie under load, bound how
  // well the wheels know r whatever the data (prior_sd below).
  double track_tolerance = 0.005;
};

struct WheelYawEvidence {
  bool available = false;
  double scale = 0;       // s - 1: r_meas = s (v_RR - v_RL)/t + ...
  double se = 0;          // chunk-clustered
  double prior_sd = 0;    // sqrt(se^2 + track_tolerance^2)
  double radius_diff = 0;     // delta: (v_RR - v_RL) per unit of speed beyond r t (a rolling-radius difference)
  double load_per_g = 0;      // kappa g: the difference per unit of speed per g of a_y
  int chunks = 0;
  long rows = 0;
  std::string note;       // why not available, or what it measured
};

// track_rear_m: vehicle.track_rear_m (> 0). Segments without the rear wheel difference or the
// yaw rate are skipped.
WheelYawEvidence EstimateWheelYawScale(const std::vector<const Segment*>& segments, double track_rear_m,
                                       const WheelYawOptions& options = {});

}  // namespace ndsid::stats
