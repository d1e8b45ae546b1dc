// Incremental re-identification (docs/incremental.md): the information of data already fitted,
// kept per chunk as its Gauss-Newton quadratic at the estimate it was last fitted at (the
// Laplace approximation fixed-lag smoothers use to marginalise old states), so that an update
// simulates only the new data plus the chunks whose linearisation point the estimate has left.
// Everything is in the identifier's scaled parameters theta (p_i = theta_i * scale_i) and in
// its weighted residuals, so a window is only usable with the model, scaling and output weights
// it was built with (Compatible()).
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ndsid/common/json_codec.h"

namespace ndsid::identify {

// One chunk's quadratic: with d = theta - theta_lin, its weighted residuals' sum of squares is
//   rss + 2 score'd + d' jtj d     (e ~ e_lin + J d),
// and its score J'e at theta is score + jtj d (the cluster-robust covariance).
struct LinearizedChunk {
  std::vector<double> theta;  // linearisation point (np)
  std::vector<double> jtj;    // J'J, row-major np x np
  std::vector<double> score;  // J'e at theta (np)
  double rss = 0;             // weighted residuals' sum of squares at theta
  double rss_a_y = 0;         // unweighted, per output, at theta (reported RMSE)
  double rss_yaw_rate = 0;
  uint32_t n_a_y = 0;         // residuals per output
  uint32_t n_yaw_rate = 0;
  // Weighted residuals' autocorrelation sums (lags 0..kMaxLag) per output: the pooled
  // autocorrelation time and noise level of the window.
  std::vector<double> acf_a_y, acf_yaw_rate;
  // The yaw-rate output's part of jtj and score (weighted as they are), so the a_y part is the
  // rest: with both, the quadratic can be re-weighted exactly (LinearizedWindow::Reweighted).
  // Empty for a prior of a_y alone and in states written before they were kept.
  std::vector<double> jtj_yaw_rate, score_yaw_rate;
};

// The chunks of one gated segment of the window (identified by drive, start and length).
struct LinearizedSegment {
  int64_t drive_id = 0;
  int64_t t0_ns = 0;
  uint64_t samples = 0;
  std::vector<LinearizedChunk> chunks;
};

struct LinearizedWindow {
  std::string model;           // ModelSpec::Describe() of the fit
  std::vector<double> scale;   // theta scaling
  double weight_a_y = 1.0;     // output weights of the residuals
  double weight_yaw_rate = 0.0;
  double chunk_s = 0, burn_in_s = 0;
  std::vector<LinearizedSegment> segments;
  // The held-out segments' chunks, for the held-out RMSE of the next update: unweighted (output
  // weights 1, so jtj, score and rss are the sums of both outputs and *_yaw_rate the yaw rate's
  // part), without autocorrelation sums. Not part of the fit; Reweighted leaves them as they are.
  // Empty in states written before they were kept (the held-out drives are then simulated).
  std::vector<LinearizedSegment> held_out;
  int updates_since_full = 0;  // incremental updates since the last full-window refit
  // The estimate of the fit that built this window, where its quadratics passed the EG check (or
  // were all fresh): an update whose solution stays within a hundredth of a standard deviation of
  // it on the same quadratics need not check them again. Not part of the learned state (a
  // restored window has none, and its first update checks).
  std::vector<double> checked_at;

  size_t chunks() const;
  // Whether every chunk keeps its yaw-rate part (two outputs): only then can it be re-weighted.
  bool Reweightable() const;
  // The same quadratics for other output weights: each chunk's a_y part scaled by
  // (weight_a_y' / weight_a_y)^2 and its yaw-rate part by (weight_yaw_rate' / weight_yaw_rate)^2,
  // as are its weighted sum of squares and autocorrelation sums. Requires Reweightable().
  LinearizedWindow Reweighted(double weight_a_y_now, double weight_yaw_rate_now) const;
  // Same model, scaling, chunking and a consistent layout: only then can its quadratics join a fit.
  bool Compatible(const std::string& model_description, const std::vector<double>& scale_now, double chunk_s_now,
                  double burn_in_s_now) const;

  // Learned state (docs/state-format.md): numbers as float64 byte strings, checked on reading
  // (sizes, finiteness, a positive semi-definite diagonal); CodecError names the bad value.
  nlohmann::json ToJson() const;
  static LinearizedWindow FromJson(const JsonIn& in);
};

}  // namespace ndsid::identify
