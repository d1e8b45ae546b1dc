#include "ndsid/stats/instrumented_stats.h"

#include <Eigen/Dense>
#include <cmath>

namespace ndsid::stats {
namespace {
using Mat3 = Eigen::Matrix<double, 3, 3, Eigen::RowMajor>;
Mat3 AsMat(const std::array<double, 9>& a) { return Eigen::Map<const Mat3>(a.data()); }
Eigen::Vector3d AsVec(const std::array<double, 3>& a) { return Eigen::Map<const Eigen::Vector3d>(a.data()); }
bool AllFinite(const InstrumentedStats::Vec& v) { return std::isfinite(v[0]) && std::isfinite(v[1]) && std::isfinite(v[2]); }
}  // namespace

void InstrumentedStats::Add(const Vec& x, const Vec& z, double y, double w) noexcept {
  if (!AllFinite(x) || !AllFinite(z) || !std::isfinite(y) || !std::isfinite(w)) return;
  for (int i = 0; i < kDim; ++i) {
    for (int j = 0; j < kDim; ++j) {
      xtx_[i * kDim + j] += w * x[i] * x[j];
      ztx_[i * kDim + j] += w * z[i] * x[j];
      ztz_[i * kDim + j] += w * z[i] * z[j];
    }
    xty_[i] += w * x[i] * y;
    zty_[i] += w * z[i] * y;
  }
  yty_ += w * y * y;
  n_ += w;
  m_ += 1;
}

void InstrumentedStats::Merge(const InstrumentedStats& o) noexcept {
  for (int i = 0; i < 9; ++i) xtx_[i] += o.xtx_[i], ztx_[i] += o.ztx_[i], ztz_[i] += o.ztz_[i];
  for (int i = 0; i < 3; ++i) xty_[i] += o.xty_[i], zty_[i] += o.zty_[i];
  yty_ += o.yty_;
  n_ += o.n_;
  m_ += o.m_;
}

void InstrumentedStats::Forget(double f) noexcept {
  for (int i = 0; i < 9; ++i) xtx_[i] *= f, ztx_[i] *= f, ztz_[i] *= f;
  for (int i = 0; i < 3; ++i) xty_[i] *= f, zty_[i] *= f;
  yty_ *= f;
  n_ *= f;
  m_ *= f;
}

LsSolution InstrumentedStats::Solve() const {
  LsSolution s = LsSolutionWithCounts(n_, m_);
  if (!s.reason.empty()) return s;
  const Mat3 a = AsMat(ztx_);
  // Conditioning on the scaled matrix (unit diagonals of Z'WZ and X'WX), as RegressionStats does.
  Eigen::Vector3d dz, dx;
  for (int i = 0; i < 3; ++i) {
    dz[i] = ztz_[i * 4] > 0 ? 1.0 / std::sqrt(ztz_[i * 4]) : 0.0;
    dx[i] = xtx_[i * 4] > 0 ? 1.0 / std::sqrt(xtx_[i * 4]) : 0.0;
  }
  if (dz.minCoeff() == 0 || dx.minCoeff() == 0) {
    s.reason = "a regressor or an instrument is identically zero";
    return s;
  }
  const Mat3 scaled = dz.asDiagonal() * a * dx.asDiagonal();
  const Eigen::FullPivLU<Mat3> lu(scaled);
  if (!(std::abs(scaled.determinant()) > 1e-12) || !lu.isInvertible()) {
    s.reason = "regressors are collinear (not enough variety in speed and lateral acceleration)";
    return s;
  }
  const Mat3 a_inv = dx.asDiagonal() * lu.inverse() * dz.asDiagonal();
  const Eigen::Vector3d theta = a_inv * AsVec(zty_);
  const Mat3 xtx = AsMat(xtx_);
  const double rss = std::max(yty_ - 2 * theta.dot(AsVec(xty_)) + theta.dot(xtx * theta), 0.0);
  s.sigma = std::sqrt(rss / std::max(m_ - 3.0, 1.0));
  const Mat3 cov = s.sigma * s.sigma * a_inv * AsMat(ztz_) * a_inv.transpose();
  for (int i = 0; i < 3; ++i) {
    s.theta[i] = theta[i];
    for (int j = 0; j < 3; ++j) s.covariance[i * 3 + j] = cov(i, j);
  }
  s.valid = true;
  return s;
}

nlohmann::json InstrumentedStats::ToJson() const {
  return {{"xtx", xtx_}, {"xty", xty_}, {"yty", yty_}, {"ztx", ztx_}, {"ztz", ztz_}, {"zty", zty_}, {"n", n_}, {"m", m_}};
}

InstrumentedStats InstrumentedStats::FromJson(const JsonIn& in) {
  InstrumentedStats r;
  auto read = [&](const char* key, auto& out) {
    const JsonIn a = in.At(key);
    if (a.Size(out.size()) != out.size()) a.Fail("needs " + std::to_string(out.size()) + " numbers");
    for (size_t i = 0; i < out.size(); ++i) out[i] = a.At(i).Finite();
  };
  read("xtx", r.xtx_);
  read("xty", r.xty_);
  read("ztx", r.ztx_);
  read("ztz", r.ztz_);
  read("zty", r.zty_);
  r.yty_ = in.Finite("yty");
  r.n_ = in.Finite("n");
  r.m_ = in.Finite("m");
  if (r.n_ < 0) in.At("n").Fail("negative");
  if (r.m_ < 0) in.At("m").Fail("negative");
  return r;
}

}  // namespace ndsid::stats
