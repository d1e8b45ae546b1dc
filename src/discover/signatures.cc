#include "signatures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string_view>
#include <tuple>

namespace ndsid::discover {
namespace {

struct Signature {
  const char* key;  // SignatureCorrelation::key
  const char* name;
  double (*value)(const stats::SegmentSample* s, size_t k, size_t n, double dt, double w);
};

double SteerRate(const stats::SegmentSample* s, size_t k, size_t n, double dt) {
  const size_t a = k > 0 ? k - 1 : k, b = k + 1 < n ? k + 1 : k;
  return b > a ? (s[b].steer_rad - s[a].steer_rad) / ((b - a) * dt) : 0.0;
}

const Signature kSignatures[] = {
    {"bias", "constant (bias)", [](const stats::SegmentSample*, size_t, size_t, double, double) { return 1.0; }},
    {"a_y", "a_y (scale, roll)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) { return double(s[k].lat_accel_mps2); }},
    {"a_y3", "a_y^3 (tyre nonlinearity)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) {
       const double a = s[k].lat_accel_mps2;
       return a * a * a;
     }},
    {"a_y2", "a_y^2 (accelerometer nonlinearity, even)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) {
       const double a = s[k].lat_accel_mps2;
       return a * a;
     }},
    {"w", "w(v) = v^2/(l+EG v^2) (straight-line offset)", [](const stats::SegmentSample*, size_t, size_t, double, double w) { return w; }},
    {"w_a_y", "w(v)*a_y (EG error)", [](const stats::SegmentSample* s, size_t k, size_t, double, double w) { return w * s[k].lat_accel_mps2; }},
    {"steer_odd", "w(v)*sgn(steering) (offset odd in the steering: on-centre play)",
     [](const stats::SegmentSample* s, size_t k, size_t, double, double w) {
       const double d = s[k].steer_rad;
       return d > 0 ? w : d < 0 ? -w : 0.0;
     }},
    {"steer_even", "w(v)*|steering| (offset even in the steering: unequal left and right)",
     [](const stats::SegmentSample* s, size_t k, size_t, double, double w) { return w * std::fabs(double(s[k].steer_rad)); }},
    {"steer_rate", "steering rate (lag)", [](const stats::SegmentSample* s, size_t k, size_t n, double dt, double) { return SteerRate(s, k, n, dt); }},
    {"steer_rate_v", "steering rate / v (low-speed lag)", [](const stats::SegmentSample* s, size_t k, size_t n, double dt, double) {
       return SteerRate(s, k, n, dt) / std::max(1.0, double(s[k].speed_mps));
     }},
    {"a_x", "a_x (longitudinal)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) { return double(s[k].long_accel_mps2); }},
    {"a_x_a_y", "a_x*a_y (load transfer)", [](const stats::SegmentSample* s, size_t k, size_t, double, double) {
       return double(s[k].long_accel_mps2) * s[k].lat_accel_mps2;
     }},
};
constexpr int kNumSignatures = sizeof(kSignatures) / sizeof(kSignatures[0]);
// The controls of PartialSlope: the constant, a_y, a_y^3 and w(v) sgn(d_sw), every shape odd in
// the turn that a scale, a saturation, a bank into the curve or a play leaves; and the even
// shapes it is taken for.
int IndexOf(std::string_view key) {
  for (int s = 0; s < kNumSignatures; ++s)
    if (key == kSignatures[s].key) return s;
  return -1;
}
const int kBias = IndexOf("bias"), kW = IndexOf("w"), kAy = IndexOf("a_y"), kAy3 = IndexOf("a_y3"), kSteerOdd = IndexOf("steer_odd"),
          kAy2 = IndexOf("a_y2"), kSteerEven = IndexOf("steer_even");

}  // namespace

SignatureSums::SignatureSums(double wheelbase_m, double eg_rad_per_mps2)
    : wheelbase_m_(wheelbase_m), eg_(eg_rad_per_mps2), a_y_(kNumSignatures), kinematic_(kNumSignatures) {}

SignatureSums::OutputSums::OutputSums(int signatures)
    : sums(Eigen::MatrixXd::Zero(signatures, 2)), xx(Eigen::MatrixXd::Zero(signatures, signatures)) {}

void SignatureSums::OutputSums::BeginChunk() {
  chunk_xe.push_back(Eigen::VectorXd::Zero(sums.rows()));
  chunk_e_sum.push_back(0.0);
  chunk_xx.push_back(Eigen::MatrixXd::Zero(sums.rows(), sums.rows()));
}

void SignatureSums::OutputSums::Add(const Eigen::VectorXd& x, double e) {
  rss += e * e;
  sum_e += e;
  ++n;
  sums.col(0) += x;
  sums.col(1) += x.cwiseProduct(x);
  xx.selfadjointView<Eigen::Lower>().rankUpdate(x);
  chunk_xe.back() += x * e;
  chunk_e_sum.back() += e;
  chunk_xx.back().selfadjointView<Eigen::Lower>().rankUpdate(x);
}

std::pair<double, double> SignatureSums::OutputSums::PartialSlope(int s) const {
  constexpr int kN = 6;
  const int idx[kN] = {kBias, kW, kAy, kAy3, kSteerOdd, s};
  using Mat = Eigen::Matrix<double, kN, kN>;
  using Vec = Eigen::Matrix<double, kN, 1>;
  auto at = [](const Eigen::MatrixXd& m, int i, int j) { return m(std::max(i, j), std::min(i, j)); };  // lower triangle
  Mat a;
  Vec g = Vec::Zero();
  for (int i = 0; i < kN; ++i)
    for (int j = 0; j < kN; ++j) a(i, j) = at(xx, idx[i], idx[j]);
  for (const Eigen::VectorXd& c : chunk_xe)
    for (int i = 0; i < kN; ++i) g[i] += c[idx[i]];
  const Eigen::LDLT<Mat> ldlt(a);
  if (ldlt.info() != Eigen::Success || !(ldlt.rcond() > 1e-12)) return {0.0, 0.0};
  const Vec b = ldlt.solve(g);
  Mat meat = Mat::Zero();
  for (size_t c = 0; c < chunk_xe.size(); ++c) {
    Vec u;
    for (int i = 0; i < kN; ++i) {
      u[i] = chunk_xe[c][idx[i]];
      for (int j = 0; j < kN; ++j) u[i] -= at(chunk_xx[c], idx[i], idx[j]) * b[j];
    }
    meat += u * u.transpose();
  }
  const Mat ai = ldlt.solve(Mat::Identity());
  const double var = (ai * meat * ai)(kN - 1, kN - 1);
  return {b[kN - 1], var > 0 ? std::sqrt(var) : 0.0};
}

void SignatureSums::AddChunk(const identify::Chunk& c, size_t burn, const std::vector<double>& e, size_t n_rows_a,
                             double a_y_weight) {
  const bool yaw = c.has_yaw_rate();
  a_y_.BeginChunk();
  if (yaw) kinematic_.BeginChunk();
  Eigen::VectorXd x(kNumSignatures);
  for (size_t k = 0; k < n_rows_a; ++k) {
    const size_t kk = burn + k;
    const stats::SegmentSample& p = c.samples[kk];
    const double v = p.speed_mps;
    const double w = v * v / (wheelbase_m_ + eg_ * v * v);
    for (int s = 0; s < kNumSignatures; ++s) x[s] = kSignatures[s].value(c.samples, kk, c.n, c.dt_s, w);
    a_y_.Add(x, e[k]);
    if (yaw) kinematic_.Add(x, a_y_weight * (double(p.lat_accel_mps2) - v * double(p.yaw_rate_radps)));
  }
}

std::vector<SignatureCorrelation> SignatureSums::OutputSums::Correlations() const {
  std::vector<SignatureCorrelation> out;
  if (n == 0) return out;
  const double n_sig = static_cast<double>(n);
  const double mean_e = sum_e / n_sig;
  for (int s = 0; s < kNumSignatures; ++s) {
    SignatureCorrelation sc;
    sc.key = kSignatures[s].key;
    sc.signal = kSignatures[s].name;
    const double mean_x = sums(s, 0) / n_sig;
    const double sxx = sums(s, 1) - n_sig * mean_x * mean_x;
    double sxe = 0, var = 0;
    for (size_t c = 0; c < chunk_xe.size(); ++c) {
      // sum over the chunk of (x - mean_x) e: exact as the centred covariance when summed over all chunks
      const double part = chunk_xe[c][s] - mean_x * chunk_e_sum[c];
      sxe += part;
      var += part * part;
    }
    if (sxx > 0 && rss > 0) {
      const double see = rss - n_sig * mean_e * mean_e;
      sc.correlation = sxe / std::sqrt(sxx * std::max(see, 1e-300));
      sc.drss = sxe * sxe / sxx;
      sc.z_robust = var > 0 ? sxe / std::sqrt(var) : 0.0;
      if (s == kAy2 || s == kSteerEven) std::tie(sc.slope, sc.slope_se) = PartialSlope(s);
    }
    out.push_back(sc);
  }
  std::sort(out.begin(), out.end(), [](const auto& a, const auto& b) { return a.drss > b.drss; });
  return out;
}

bool IsUnexplained(const SignatureCorrelation& top, double best_candidate_drss, double rss, double z_threshold) {
  return std::abs(top.z_robust) > z_threshold && top.drss > 2.0 * best_candidate_drss && top.drss > 0.01 * rss;
}

void JudgeUnexplained(Diagnosis& d, double rss, double z_threshold) {
  double best_candidate = 0;
  for (const auto& c : d.ranked) {
    if (c.significant) best_candidate = std::max(best_candidate, c.drss);
  }
  if (d.signatures.empty()) return;
  const auto& top = d.signatures.front();
  if (!IsUnexplained(top, best_candidate, rss, z_threshold)) return;
  d.unexplained = true;
  char buf[256];
  std::snprintf(buf, sizeof buf,
                "residual structure no library effect explains: it correlates with %s (r = %.2f, z = %.1f, "
                "explains %.1f %% of the RSS)",
                top.signal.c_str(), top.correlation, top.z_robust, 100 * top.drss / rss);
  d.unexplained_text = buf;
}

}  // namespace ndsid::discover
