// The speed signal's scale against the longitudinal accelerometer (docs/two-outputs.md, "A speed
// scale, read from a_x"): model-free evidence for the `speed_scale` effect, which the lateral
// outputs cannot separate from an accelerometer scale. With v_meas = (1 + eps) v,
//   (v_meas(t + h) - v_meas(t - h)) / 2h = (1 + eps) * mean of a_x over [t - h, t + h]
// exactly (the window mean of a derivative is the difference quotient), so no filter distorts
// one side against the other. Road grade and an accelerometer bias add a slowly varying term to
// a_x: both sides are demeaned per chunk, a_x is regressed on dv_meas/dt (the grade's variation
// within a chunk and the accelerometer's noise are in a_x, where they do not bias the slope), and
// the slope's standard error is clustered by chunk.
// What it measures is the speed's scale relative to the accelerometer's: eps - k_ax.
#pragma once

#include <string>
#include <vector>

#include "ndsid/stats/segment.h"

namespace ndsid::stats {

struct SpeedScaleOptions {
  double half_window_s = 0.5;   // h
  double chunk_s = 30.0;        // demeaning and clustering unit
  int min_chunks = 10;          // fewer: no evidence
  double min_accel_sd_mps2 = 0.2;  // chunks whose speed hardly changes (sd of dv_meas/dt) carry no scale information
  double max_abs_scale = 0.2;   // |eps| above: the a_x role disagrees with the speed (sign or unit), no evidence
  // The evidence measures eps - k_ax: the accelerometer's own scale tolerance bounds how well it
  // knows eps, whatever the data (prior_sd below).
  double accel_scale_tolerance = 0.005;
};

struct SpeedScaleEvidence {
  bool available = false;
  double scale = 0;       // eps: dv_meas/dt = (1 + eps) a_x
  double se = 0;          // chunk-clustered
  double prior_sd = 0;    // sqrt(se^2 + accel_scale_tolerance^2): the sd of the prior it gives speed_scale
  int chunks = 0;
  long samples = 0;
  std::string note;       // why not available, or what it measured
};

SpeedScaleEvidence EstimateSpeedScale(const std::vector<const Segment*>& segments, const SpeedScaleOptions& options = {});

}  // namespace ndsid::stats
