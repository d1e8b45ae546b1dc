// Sufficient statistics of a 3-regressor weighted linear least-squares problem y = x' theta + e:
// X'WX, X'Wy, y'Wy, the weights' sum n and the number of observations m. Exact, O(1) memory,
// mergeable by addition, optional exponential forgetting. The residual variance counts m - 3
// degrees of freedom: an observation may be the mean of many samples, weighted by their count.
#pragma once

#include <array>
#include <string>

#include "ndsid/common/json_codec.h"

namespace ndsid::stats {

struct LsSolution {
  bool valid = false;
  std::string reason;                 // why not valid
  std::array<double, 3> theta{};
  std::array<double, 9> covariance{}; // sigma^2 (X'WX)^-1, row-major
  double sigma = 0;                   // residual standard deviation (per unit weight)
  double n = 0;                       // sum of the weights
  double m = 0;                       // observations
};

// A solution that carries the counts n and m: not valid, with its reason, below 10 observations
// (what every solver here checks first).
LsSolution LsSolutionWithCounts(double n, double m);

class RegressionStats {
 public:
  static constexpr int kDim = 3;
  // A sample with a non-finite regressor, y or weight is ignored (it would poison every later
  // Solve() and the persisted state); the gate upstream already rejects such samples.
  // Each call is one observation (m += 1) of weight `weight` (n += weight).
  void Add(const std::array<double, kDim>& x, double y, double weight = 1.0) noexcept;
  void Merge(const RegressionStats& other) noexcept;  // statistics of the union of the data
  void Forget(double factor) noexcept;                 // scales everything by factor in (0, 1]
  LsSolution Solve() const;

  const std::array<double, 9>& xtx() const { return xtx_; }
  const std::array<double, 3>& xty() const { return xty_; }
  double yty() const { return yty_; }
  double n() const { return n_; }
  double m() const { return m_; }

  // {"xtx": [9], "xty": [3], "yty": x, "n": x, "m": x}: exact round trip; "m" is written only
  // where it differs from n, and a document without it (every sample its own observation) reads
  // m = n. FromJson throws CodecError naming the missing, malformed or non-finite number (or a
  // negative n or m).
  nlohmann::json ToJson() const;
  static RegressionStats FromJson(const JsonIn& in);

  bool operator==(const RegressionStats&) const = default;

 private:
  std::array<double, 9> xtx_{};
  std::array<double, 3> xty_{};
  double yty_ = 0;
  double n_ = 0;
  double m_ = 0;
};

}  // namespace ndsid::stats
