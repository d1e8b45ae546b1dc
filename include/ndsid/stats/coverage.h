// Where the data lie: occupancy of (a_x, a_y) bins (the g-g diagram, against Kamm's circle) and
// (v, a_y) bins, and the information growth of that distribution as the Kullback-Leibler
// divergence between the histogram now and a snapshot taken earlier.
#pragma once

#include <cstdint>
#include <string>
#include <vector>

#include "ndsid/common/json_codec.h"
#include "ndsid/gate/gate.h"

namespace ndsid::stats {

struct Histogram2d {
  double x_min = 0, x_max = 0, y_min = 0, y_max = 0;
  int nx = 0, ny = 0;
  std::vector<double> counts;  // row-major [ix * ny + iy]

  Histogram2d() = default;
  Histogram2d(double x_min, double x_max, int nx, double y_min, double y_max, int ny);
  // Values outside go to the edge bins (however far out); non-finite x or y are ignored.
  void Add(double x, double y, double w = 1.0) noexcept;
  double total() const;
  void Merge(const Histogram2d& o);
};

// KL(p || q) in nats of two histograms of the same shape, each normalised, with a small
// uniform prior worth `prior_samples` samples in all (spread over the bins) so empty bins
// give large but finite terms.
double KlDivergence(const Histogram2d& p, const Histogram2d& q, double prior_samples = 1.0);

class Coverage {
 public:
  Coverage();
  void Add(const gate::GatedSample& g) noexcept;  // accepted samples only
  void Merge(const Coverage& o);

  const Histogram2d& gg() const { return gg_; }    // x = a_x, y = a_y [m/s^2]
  const Histogram2d& v_ay() const { return v_ay_; } // x = v [m/s], y = a_y [m/s^2]
  // Share of accepted samples with |a_y| below each limit (1, 2, 4 m/s^2).
  double ShareBelow(double abs_ay_mps2) const;

  // {"gg": [counts], "v_ay": [counts]} (the bins are fixed); FromJson checks the sizes and
  // that every count is finite and >= 0.
  nlohmann::json ToJson() const;
  static Coverage FromJson(const JsonIn& in);

 private:
  Histogram2d gg_;
  Histogram2d v_ay_;
};

}  // namespace ndsid::stats
