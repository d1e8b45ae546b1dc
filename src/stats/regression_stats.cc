#include "ndsid/stats/regression_stats.h"

#include <cmath>
#include <string>

#include "ndsid/common/error.h"

namespace ndsid::stats {

void RegressionStats::Add(const std::array<double, kDim>& x, double y, double w) noexcept {
  if (!std::isfinite(x[0]) || !std::isfinite(x[1]) || !std::isfinite(x[2]) || !std::isfinite(y) || !std::isfinite(w)) return;
  for (int i = 0; i < kDim; ++i) {
    for (int j = 0; j < kDim; ++j) xtx_[i * kDim + j] += w * x[i] * x[j];
    xty_[i] += w * x[i] * y;
  }
  yty_ += w * y * y;
  n_ += w;
  m_ += 1;
}

void RegressionStats::Merge(const RegressionStats& o) noexcept {
  for (int i = 0; i < 9; ++i) xtx_[i] += o.xtx_[i];
  for (int i = 0; i < 3; ++i) xty_[i] += o.xty_[i];
  yty_ += o.yty_;
  n_ += o.n_;
  m_ += o.m_;
}

void RegressionStats::Forget(double f) noexcept {
  for (double& v : xtx_) v *= f;
  for (double& v : xty_) v *= f;
  yty_ *= f;
  n_ *= f;
  m_ *= f;
}

LsSolution LsSolutionWithCounts(double n, double m) {
  LsSolution s;
  s.n = n;
  s.m = m;
  if (m < 10) s.reason = "fewer than 10 observations";
  return s;
}

LsSolution RegressionStats::Solve() const {
  LsSolution s = LsSolutionWithCounts(n_, m_);
  if (!s.reason.empty()) return s;
  // Symmetric 3x3 inverse by cofactors, on the matrix scaled to unit diagonal for conditioning.
  std::array<double, 3> d{};
  for (int i = 0; i < 3; ++i) d[i] = xtx_[i * 4] > 0 ? 1.0 / std::sqrt(xtx_[i * 4]) : 0.0;
  if (d[0] == 0 || d[1] == 0 || d[2] == 0) {
    s.reason = "a regressor is identically zero";
    return s;
  }
  double a[9];
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) a[i * 3 + j] = xtx_[i * 3 + j] * d[i] * d[j];
  const double c00 = a[4] * a[8] - a[5] * a[7], c01 = a[5] * a[6] - a[3] * a[8], c02 = a[3] * a[7] - a[4] * a[6];
  const double det = a[0] * c00 + a[1] * c01 + a[2] * c02;
  if (!(std::abs(det) > 1e-12)) {
    s.reason = "regressors are collinear (not enough variety in speed and lateral acceleration)";
    return s;
  }
  double inv[9] = {c00, a[2] * a[7] - a[1] * a[8], a[1] * a[5] - a[2] * a[4],
                   c01, a[0] * a[8] - a[2] * a[6], a[2] * a[3] - a[0] * a[5],
                   c02, a[1] * a[6] - a[0] * a[7], a[0] * a[4] - a[1] * a[3]};
  for (double& v : inv) v /= det;
  for (int i = 0; i < 3; ++i) {
    double t = 0;
    for (int j = 0; j < 3; ++j) t += inv[i * 3 + j] * d[i] * d[j] * xty_[j];
    s.theta[i] = t;
  }
  // RSS = y'y - 2 theta'X'y + theta'X'X theta = y'y - theta'X'y at the optimum.
  double rss = yty_;
  for (int i = 0; i < 3; ++i) rss -= s.theta[i] * xty_[i];
  rss = std::max(rss, 0.0);
  const double dof = std::max(m_ - 3.0, 1.0);
  s.sigma = std::sqrt(rss / dof);
  for (int i = 0; i < 3; ++i)
    for (int j = 0; j < 3; ++j) s.covariance[i * 3 + j] = s.sigma * s.sigma * inv[i * 3 + j] * d[i] * d[j];
  s.valid = true;
  return s;
}

nlohmann::json RegressionStats::ToJson() const {
  nlohmann::json j = {{"xtx", xtx_}, {"xty", xty_}, {"yty", yty_}, {"n", n_}};
  if (m_ != n_) j["m"] = m_;  // absent: every sample its own observation
  return j;
}

RegressionStats RegressionStats::FromJson(const JsonIn& in) {
  RegressionStats r;
  const JsonIn xtx = in.At("xtx"), xty = in.At("xty");
  if (xtx.Size(9) != 9) xtx.Fail("needs 9 numbers (X'X row-major)");
  if (xty.Size(3) != 3) xty.Fail("needs 3 numbers (X'y)");
  for (size_t i = 0; i < 9; ++i) r.xtx_[i] = xtx.At(i).Finite();
  for (size_t i = 0; i < 3; ++i) r.xty_[i] = xty.At(i).Finite();
  r.yty_ = in.Finite("yty");
  r.n_ = in.Finite("n");
  if (r.n_ < 0) in.At("n").Fail("negative");
  r.m_ = in.Has("m") ? in.Finite("m") : r.n_;
  if (r.m_ < 0) in.At("m").Fail("negative");
  return r;
}

}  // namespace ndsid::stats
