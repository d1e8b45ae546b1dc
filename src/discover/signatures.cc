#include "signatures.h"

#include <algorithm>
#include <cmath>
#include <cstdio>

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

}  // namespace

SignatureSums::SignatureSums(double wheelbase_m, double eg_rad_per_mps2)
    : wheelbase_m_(wheelbase_m), eg_(eg_rad_per_mps2), sums_(Eigen::MatrixXd::Zero(kNumSignatures, 4)) {}

void SignatureSums::AddChunk(const identify::Chunk& c, size_t burn, const std::vector<double>& e, size_t n_rows_a) {
  for (size_t k = 0; k < n_rows_a; ++k) rss_ += e[k] * e[k];
  n_ += n_rows_a;
  Eigen::VectorXd xe = Eigen::VectorXd::Zero(kNumSignatures);
  double esum = 0;
  for (int k = 0; k < static_cast<int>(n_rows_a); ++k) {
    const size_t kk = burn + static_cast<size_t>(k);
    const double v = c.samples[kk].speed_mps;
    const double w = v * v / (wheelbase_m_ + eg_ * v * v);
    esum += e[static_cast<size_t>(k)];
    for (int s = 0; s < kNumSignatures; ++s) {
      const double val = kSignatures[s].value(c.samples, kk, c.n, c.dt_s, w);
      sums_(s, 0) += val;
      sums_(s, 1) += val * val;
      xe[s] += val * e[static_cast<size_t>(k)];
    }
  }
  sum_e_ += esum;
  chunk_xe_.push_back(xe);
  chunk_e_sum_.push_back(esum);
}

std::vector<SignatureCorrelation> SignatureSums::Correlations() const {
  std::vector<SignatureCorrelation> out;
  const double n_sig = static_cast<double>(n_);
  const double mean_e = n_sig > 0 ? sum_e_ / n_sig : 0.0;
  for (int s = 0; s < kNumSignatures; ++s) {
    SignatureCorrelation sc;
    sc.key = kSignatures[s].key;
    sc.signal = kSignatures[s].name;
    const double mean_x = n_sig > 0 ? sums_(s, 0) / n_sig : 0.0;
    const double sxx = sums_(s, 1) - n_sig * mean_x * mean_x;
    double sxe = 0, var = 0;
    for (size_t c = 0; c < chunk_xe_.size(); ++c) {
      // sum over chunk of (x - mean_x)(e - mean_e) = xe - mean_x*esum - mean_e*sum_x + n mean_x mean_e; use
      // the uncentred-x form with centred e (exact when summed over all chunks).
      const double part = chunk_xe_[c][s] - mean_e * 0.0 - mean_x * chunk_e_sum_[c];
      sxe += part;
      var += part * part;
    }
    if (sxx > 0 && rss_ > 0) {
      const double see = rss_ - n_sig * mean_e * mean_e;
      sc.correlation = sxe / std::sqrt(sxx * std::max(see, 1e-300));
      sc.drss = sxe * sxe / sxx;
      sc.z_robust = var > 0 ? sxe / std::sqrt(var) : 0.0;
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
