#include "ndsid/stats/wheel_yaw.h"

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>

#include "ndsid/common/format.h"

namespace ndsid::stats {
namespace {

constexpr int kMaxTerms = 3;  // (v_RR - v_RL)/t, v/t, a_y v/t
constexpr double kGravity_mps2 = 9.80665;

// One 0.5 s block: the gyro's yaw rate, the regressors and their instruments.
struct Row {
  double y;
  double x[kMaxTerms];
  double z[kMaxTerms];
};

// The blocks of one chunk, demeaned, or nothing where the chunk carries no scale (too little yaw).
std::vector<Row> Demeaned(std::vector<Row> rows, const WheelYawOptions& o) {
  if (rows.size() < 4) return {};
  Row mean{};
  for (const Row& r : rows) {
    mean.y += r.y;
    for (int j = 0; j < kMaxTerms; ++j) mean.x[j] += r.x[j], mean.z[j] += r.z[j];
  }
  const double n = static_cast<double>(rows.size());
  double var = 0;
  for (Row& r : rows) {
    r.y -= mean.y / n;
    for (int j = 0; j < kMaxTerms; ++j) r.x[j] -= mean.x[j] / n, r.z[j] -= mean.z[j] / n;
    var += r.y * r.y;
  }
  if (std::sqrt(var / n) < o.min_yaw_sd_radps) return {};
  return rows;
}

// The chunks of one segment: 0.5 s block means, gated for slip.
void AddSegment(const Segment& seg, double track_m, const WheelYawOptions& o, std::vector<std::vector<Row>>& chunks) {
  const long per_block = std::max(1L, std::lround(o.block_s / seg.dt_s));
  const long per_chunk = std::max(1L, std::lround(o.chunk_s / o.block_s));
  const auto n = static_cast<long>(seg.samples.size());
  std::vector<Row> chunk;
  auto close = [&] {
    std::vector<Row> d = Demeaned(std::move(chunk), o);
    if (!d.empty()) chunks.push_back(std::move(d));
    chunk.clear();
  };
  for (long b0 = 0; b0 + per_block <= n; b0 += per_block) {
    double r = 0, d = 0, v = 0, ay = 0, ax_max = 0;
    for (long k = b0; k < b0 + per_block; ++k) {
      const SegmentSample& s = seg.samples[k];
      r += s.yaw_rate_radps, d += s.rear_wheel_diff_mps, v += s.speed_mps, ay += s.lat_accel_mps2;
      if (seg.has_long_accel) ax_max = std::max(ax_max, std::abs(static_cast<double>(s.long_accel_mps2)));
    }
    const double m = static_cast<double>(per_block);
    r /= m, d /= m, v /= m, ay /= m;
    const bool usable = v > o.min_speed_mps && std::abs(ay) <= o.max_lat_accel_mps2 && ax_max <= o.max_long_accel_mps2 &&
                        std::isfinite(r + d + v + ay);
    if (!usable) {  // a gap in the rows: the chunk ends here
      close();
      continue;
    }
    chunk.push_back({r, {d / track_m, v / track_m, ay * v / track_m}, {ay / v, v / track_m, ay * v / track_m}});
    if (static_cast<long>(chunk.size()) == per_chunk) close();
  }
  if (static_cast<long>(chunk.size()) >= per_chunk / 2) close();
}

struct IvFit {
  bool ok = false;
  Eigen::VectorXd beta;
  Eigen::MatrixXd cov;
};

// Just-identified IV with the first `terms` regressors, chunk-clustered covariance.
IvFit FitIv(const std::vector<std::vector<Row>>& chunks, int terms) {
  IvFit f;
  Eigen::MatrixXd A = Eigen::MatrixXd::Zero(terms, terms);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(terms);
  for (const auto& c : chunks)
    for (const Row& r : c) {
      const Eigen::Map<const Eigen::VectorXd> x(r.x, terms), z(r.z, terms);
      A += z * x.transpose();
      b += z * r.y;
    }
  // Conditioning on unit-scaled columns: a term the data do not vary (the speed within chunks) is dropped.
  const Eigen::VectorXd scale = A.cwiseAbs().colwise().maxCoeff().transpose().cwiseMax(1e-300);
  const Eigen::JacobiSVD<Eigen::MatrixXd> svd(A * scale.cwiseInverse().asDiagonal());
  const Eigen::VectorXd sv = svd.singularValues();
  if (!(sv(terms - 1) > 1e-8 * sv(0))) return f;
  const Eigen::MatrixXd Ainv = A.inverse();
  f.beta = Ainv * b;
  Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(terms, terms);
  for (const auto& c : chunks) {
    Eigen::VectorXd s = Eigen::VectorXd::Zero(terms);
    for (const Row& r : c) {
      const Eigen::Map<const Eigen::VectorXd> x(r.x, terms), z(r.z, terms);
      s += z * (r.y - x.dot(f.beta));
    }
    meat += s * s.transpose();
  }
  const double g = static_cast<double>(chunks.size());
  f.cov = Ainv * meat * Ainv.transpose() * (g / (g - 1.0));
  f.ok = f.beta.allFinite() && f.cov.allFinite();
  return f;
}

}  // namespace

WheelYawEvidence EstimateWheelYawScale(const std::vector<const Segment*>& segments, double track_rear_m,
                                       const WheelYawOptions& options) {
  WheelYawEvidence out;
  if (!(track_rear_m > 0)) {
    out.note = "yaw rate against the rear wheels: vehicle.track_rear_m not given";
    return out;
  }
  std::vector<std::vector<Row>> chunks;
  for (const Segment* seg : segments) {
    if (seg == nullptr || !seg->has_rear_wheel_diff || !seg->has_yaw_rate || !(seg->dt_s > 0)) continue;
    AddSegment(*seg, track_rear_m, options, chunks);
  }
  out.chunks = static_cast<int>(chunks.size());
  for (const auto& c : chunks) out.rows += static_cast<long>(c.size());
  if (out.chunks < options.min_chunks) {
    out.note = "yaw rate against the rear wheels: " + std::to_string(out.chunks) + " chunks with turning above " +
               std::to_string(static_cast<int>(options.min_speed_mps)) + " m/s (needs " + std::to_string(options.min_chunks) + ")";
    return out;
  }
  IvFit fit;
  int terms = kMaxTerms;
  for (; terms >= 1 && !fit.ok; --terms) fit = FitIv(chunks, terms);
  ++terms;
  if (!fit.ok) {
    out.note = "yaw rate against the rear wheels: the regression is singular (no turning in the rows?)";
    return out;
  }
  const double s = fit.beta(0);
  out.scale = s - 1.0;
  out.se = std::sqrt(fit.cov(0, 0));
  // b2 = -s (1 + eps) delta, b3 = -s (1 + eps) kappa: reported relative to the wheels' own scale.
  if (terms >= 2) out.radius_diff = -fit.beta(1) / s;
  if (terms >= 3) out.load_per_g = -fit.beta(2) / s * kGravity_mps2;
  if (!std::isfinite(out.scale) || !std::isfinite(out.se) || std::abs(out.scale) > options.max_abs_scale) {
    out.note = Fmt("yaw rate against the rear wheels: r_meas = %.3f (v_RR - v_RL)/t, not within 1 +- %.2f: the "
                   "rear_wheel_speed_difference role's sign (right minus left), its unit or vehicle.track_rear_m is wrong; not used",
                   s, options.max_abs_scale);
    return out;
  }
  out.available = true;
  out.prior_sd = std::hypot(out.se, options.track_tolerance);
  out.note = Fmt("yaw rate against the rear wheels: r_meas = (1 %+.4f +- %.4f) (v_RR - v_RL)/t (rolling radii differ by %+.2f %%, "
                 "%+.2f %%/g with load; %d chunks, %ld rows)",
                 out.scale, out.se, 100 * out.radius_diff, 100 * out.load_per_g, out.chunks, out.rows);
  return out;
}

}  // namespace ndsid::stats
