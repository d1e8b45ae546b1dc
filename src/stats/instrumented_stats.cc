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
  plain_.Add(x, y, w);
  for (int i = 0; i < kDim; ++i) {
    for (int j = 0; j < kDim; ++j) {
      ztx_[i * kDim + j] += w * z[i] * x[j];
      ztz_[i * kDim + j] += w * z[i] * z[j];
    }
    zty_[i] += w * z[i] * y;
  }
}

void InstrumentedStats::Merge(const InstrumentedStats& o) noexcept {
  plain_.Merge(o.plain_);
  for (int i = 0; i < 9; ++i) ztx_[i] += o.ztx_[i], ztz_[i] += o.ztz_[i];
  for (int i = 0; i < 3; ++i) zty_[i] += o.zty_[i];
}

void InstrumentedStats::Forget(double f) noexcept {
  plain_.Forget(f);
  for (int i = 0; i < 9; ++i) ztx_[i] *= f, ztz_[i] *= f;
  for (int i = 0; i < 3; ++i) zty_[i] *= f;
}

LsSolution InstrumentedStats::Solve() const {
  LsSolution s = LsSolutionWithCounts(plain_.n(), plain_.m());
  if (!s.reason.empty()) return s;
  const Mat3 a = AsMat(ztx_), xtx = AsMat(plain_.xtx()), ztz = AsMat(ztz_);
  // Conditioning on the scaled matrix (unit diagonals of Z'WZ and X'WX), as RegressionStats does.
  Eigen::Vector3d dz, dx;
  for (int i = 0; i < 3; ++i) {
    dz[i] = ztz(i, i) > 0 ? 1.0 / std::sqrt(ztz(i, i)) : 0.0;
    dx[i] = xtx(i, i) > 0 ? 1.0 / std::sqrt(xtx(i, i)) : 0.0;
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
  const double rss = std::max(plain_.yty() - 2 * theta.dot(AsVec(plain_.xty())) + theta.dot(xtx * theta), 0.0);
  s.sigma = std::sqrt(rss / std::max(plain_.m() - 3.0, 1.0));
  const Mat3 cov = s.sigma * s.sigma * a_inv * ztz * a_inv.transpose();
  for (int i = 0; i < 3; ++i) {
    s.theta[i] = theta[i];
    for (int j = 0; j < 3; ++j) s.covariance[i * 3 + j] = cov(i, j);
  }
  s.valid = true;
  return s;
}

nlohmann::json InstrumentedStats::ToJson() const {
  nlohmann::json j = plain_.ToJson();
  j["m"] = plain_.m();  // always: a document without it would read m = n
  j["ztx"] = ztx_;
  j["ztz"] = ztz_;
  j["zty"] = zty_;
  return j;
}

InstrumentedStats InstrumentedStats::FromJson(const JsonIn& in) {
  InstrumentedStats r;
  in.Finite("m");  // required (the plain reader would take its absence as m = n)
  r.plain_ = RegressionStats::FromJson(in);
  auto read = [&](const char* key, auto& out) {
    const JsonIn a = in.At(key);
    if (a.Size(out.size()) != out.size()) a.Fail("needs " + std::to_string(out.size()) + " numbers");
    for (size_t i = 0; i < out.size(); ++i) out[i] = a.At(i).Finite();
  };
  read("ztx", r.ztx_);
  read("ztz", r.ztz_);
  read("zty", r.zty_);
  return r;
}

}  // namespace ndsid::stats
