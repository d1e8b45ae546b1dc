#include "ndsid/stats/speed_scale.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

namespace ndsid::stats {

SpeedScaleEvidence EstimateSpeedScale(const std::vector<const Segment*>& segments, const SpeedScaleOptions& options) {
  SpeedScaleEvidence out;
  // Per chunk: the demeaned pairs (window-mean a_x, difference quotient of v_meas).
  struct ChunkSums {
    double syy = 0, sxy = 0;
    std::vector<double> x, y;  // x: window mean of a_x, y: difference quotient of v_meas
  };
  std::vector<ChunkSums> chunks;
  for (const Segment* seg : segments) {
    if (seg == nullptr || !seg->has_long_accel || !(seg->dt_s > 0)) continue;
    const auto n = static_cast<long>(seg->samples.size());
    const long w = std::lround(options.half_window_s / seg->dt_s);
    const long per_chunk = std::max(1L, std::lround(options.chunk_s / seg->dt_s));
    if (w < 1 || n < 2 * w + 1) continue;
    // Cumulative trapezoid integral of a_x: any window's mean in O(1).
    std::vector<double> A(static_cast<size_t>(n), 0.0);
    for (long k = 1; k < n; ++k)
      A[k] = A[k - 1] + 0.5 * seg->dt_s * (seg->samples[k - 1].long_accel_mps2 + seg->samples[k].long_accel_mps2);
    for (long c0 = w; c0 + w < n; c0 += per_chunk) {
      ChunkSums ch;
      const long c1 = std::min(n - w, c0 + per_chunk);
      if (c1 - c0 < per_chunk / 2) break;  // a short tail chunk: too little to demean
      for (long k = c0; k < c1; ++k) {
        const double span = 2.0 * static_cast<double>(w) * seg->dt_s;
        ch.x.push_back((A[k + w] - A[k - w]) / span);
        ch.y.push_back((seg->samples[k + w].speed_mps - seg->samples[k - w].speed_mps) / span);
      }
      double mx = 0, my = 0;
      for (size_t i = 0; i < ch.x.size(); ++i) mx += ch.x[i], my += ch.y[i];
      mx /= static_cast<double>(ch.x.size());
      my /= static_cast<double>(ch.y.size());
      double sd = 0;
      for (size_t i = 0; i < ch.x.size(); ++i) {
        ch.x[i] -= mx;
        ch.y[i] -= my;
        ch.syy += ch.y[i] * ch.y[i];
        ch.sxy += ch.x[i] * ch.y[i];
        sd += ch.y[i] * ch.y[i];
      }
      if (std::sqrt(sd / static_cast<double>(ch.y.size())) < options.min_accel_sd_mps2) continue;
      chunks.push_back(std::move(ch));
    }
  }
  out.chunks = static_cast<int>(chunks.size());
  if (out.chunks < options.min_chunks) {
    out.note = "speed scale against a_x: " + std::to_string(out.chunks) + " chunks with longitudinal acceleration (needs " +
               std::to_string(options.min_chunks) + ")";
    return out;
  }
  // a_x on dv_meas/dt, not the other way round: a_x carries the grade's variation within a chunk
  // and the accelerometer's noise, which would attenuate a slope fitted on it; dv_meas/dt is
  // nearly noise-free over the window. slope = 1 / (1 + eps).
  double syy = 0, sxy = 0;
  for (const ChunkSums& c : chunks) syy += c.syy, sxy += c.sxy, out.samples += static_cast<long>(c.x.size());
  const double slope = sxy / syy;
  double meat = 0;  // cluster-robust: sum over chunks of (sum y e)^2 / syy^2
  for (const ChunkSums& c : chunks) {
    double s = 0;
    for (size_t i = 0; i < c.x.size(); ++i) s += c.y[i] * (c.x[i] - slope * c.y[i]);
    meat += s * s;
  }
  const double g = static_cast<double>(out.chunks);
  const double se_slope = std::sqrt(meat * g / (g - 1.0)) / syy;
  out.scale = 1.0 / slope - 1.0;
  out.se = se_slope / (slope * slope);
  char buf[240];
  if (!std::isfinite(out.scale) || !std::isfinite(out.se) || std::abs(out.scale) > options.max_abs_scale) {
    std::snprintf(buf, sizeof buf,
                  "speed scale against a_x: dv_meas/dt = %.3f a_x, not within 1 +- %.2f: the longitudinal_acceleration "
                  "role disagrees with the speed (its sign or unit?); not used",
                  1.0 / slope, options.max_abs_scale);
    out.note = buf;
    return out;
  }
  out.available = true;
  out.prior_sd = std::hypot(out.se, options.accel_scale_tolerance);
  std::snprintf(buf, sizeof buf, "speed scale against a_x: dv_meas/dt = (1 %+.4f +- %.4f) a_x (%d chunks, %ld samples)",
                out.scale, out.se, out.chunks, out.samples);
  out.note = buf;
  return out;
}

}  // namespace ndsid::stats
