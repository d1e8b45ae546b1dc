// Sufficient statistics of a 3-regressor instrumental-variables regression y = x' theta + e with
// instruments z (uncorrelated with e and with the noise in x): the plain regression's X'WX, X'Wy,
// y'Wy, n and m (a RegressionStats over the same observations) and Z'WX, Z'WZ, Z'Wy. Exact, O(1) memory, mergeable by addition, optional
// exponential forgetting. theta = (Z'WX)^-1 Z'Wy; its covariance
// sigma^2 (Z'WX)^-1 Z'WZ (X'WZ)^-1 with sigma^2 = sum w e^2 / (m - 3).
#pragma once

#include <array>

#include "ndsid/common/json_codec.h"
#include "ndsid/stats/regression_stats.h"

namespace ndsid::stats {

class InstrumentedStats {
 public:
  static constexpr int kDim = 3;
  using Vec = std::array<double, kDim>;
  // One observation of weight `weight`; non-finite input is ignored (as RegressionStats does).
  void Add(const Vec& x, const Vec& z, double y, double weight = 1.0) noexcept;
  void Merge(const InstrumentedStats& other) noexcept;
  void Forget(double factor) noexcept;
  LsSolution Solve() const;
  double n() const { return plain_.n(); }
  double m() const { return plain_.m(); }

  // {"xtx": [9], "xty": [3], "yty", "ztx": [9], "ztz": [9], "zty": [3], "n", "m"} (the plain
  // regression's keys, "m" always written and required): exact round trip; FromJson throws
  // CodecError naming the missing, malformed or non-finite number.
  nlohmann::json ToJson() const;
  static InstrumentedStats FromJson(const JsonIn& in);
  bool operator==(const InstrumentedStats&) const = default;

 private:
  RegressionStats plain_;  // X'WX, X'Wy, y'Wy, n, m of the same observations
  std::array<double, 9> ztx_{}, ztz_{};
  Vec zty_{};
};

}  // namespace ndsid::stats
