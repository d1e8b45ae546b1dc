#include "chunk_cost.h"
#include "parallel.h"

#include <algorithm>
#include <cmath>
#include <cstring>
#include <map>
#include <string>

namespace ndsid::identify {

// Integrated autocorrelation time of the residuals (1 + 2 sum of the autocorrelation up to the
// first lag where it turns negative), pooled over chunks: the factor by which strongly
// correlated 50 Hz residuals overstate the information in the data.
namespace {

// The lags one series contributes to: 0 .. min(kAcfMaxLag, n - 1) (lag 0 also when empty).
size_t LastLag(const std::vector<double>& e) { return std::min(kAcfMaxLag, e.empty() ? 0 : e.size() - 1); }

// sum_k e_k e_(k-lag) for lag in [first, last] (last <= LastLag(e)), written to out[lag - first]:
// the one definition of a lag's sum, so pooled and per-chunk sums agree. Each lag's products are
// added in increasing k, one running sum per lag; four lags share a pass over e, so their four
// sums are independent chains the processor overlaps (a single sum waits on each addition), and
// every sum is bit for bit that of the plain loop `for k = lag..n-1: s += e[k] * e[k - lag]`.
// (Eight scalar lags per pass measured slower at -O2: the sums no longer stay in registers.)
// Where the processor has SSE2 and the build no fused multiply-add (which could contract the
// products into the sums and change their rounding), eight lags share a pass in four two-lane
// vectors: each lane is still one lag's running sum, each product rounded before it is added,
// in increasing k, so the bits are the plain loop's (NoiseLevel.LagSumsAreTheirDefinitionBitForBit);
// about twice as fast (0.19 against 0.10 ms for 251 lags of a 3 000-sample chunk).
void LagSums(const std::vector<double>& e, size_t first, size_t last, double* out) {
  const size_t n = e.size();
  const double* x = e.data();
  size_t lag = first;
#if defined(__SSE2__) && !defined(__FMA__) && !defined(__FP_FAST_FMA)
  using V2 = double __attribute__((vector_size(16)));
  for (; lag + 7 <= last; lag += 8) {
    // Each of the eight lags' products for k < lag + 7 (lag j's start at k = lag + j), in order.
    double p[8];
    for (size_t j = 0; j < 8; ++j) {
      double s = 0;
      for (size_t k = lag + j; k < lag + 7; ++k) s += x[k] * x[k - lag - j];
      p[j] = s;
    }
    // Lanes {lag + 2m + 1, lag + 2m} of vector m: the pair x[k - lag - 2m - 1], x[k - lag - 2m].
    V2 a0 = {p[1], p[0]}, a1 = {p[3], p[2]}, a2 = {p[5], p[4]}, a3 = {p[7], p[6]};
    for (size_t k = lag + 7; k < n; ++k) {
      const V2 v = {x[k], x[k]};
      V2 y0, y1, y2, y3;
      std::memcpy(&y0, x + k - lag - 1, sizeof y0);
      std::memcpy(&y1, x + k - lag - 3, sizeof y1);
      std::memcpy(&y2, x + k - lag - 5, sizeof y2);
      std::memcpy(&y3, x + k - lag - 7, sizeof y3);
      a0 += v * y0;
      a1 += v * y1;
      a2 += v * y2;
      a3 += v * y3;
    }
    const V2 acc[4] = {a0, a1, a2, a3};
    for (size_t m = 0; m < 4; ++m) {
      out[lag + 2 * m - first] = acc[m][1];
      out[lag + 2 * m + 1 - first] = acc[m][0];
    }
  }
#endif
  for (; lag + 3 <= last; lag += 4) {
    double s0 = 0, s1 = 0, s2 = 0, s3 = 0;
    // k < lag + 3: only the lags whose first product has come (each starts at k = its lag;
    // lag + 3 <= last < n, so these samples exist).
    s0 += x[lag] * x[0];
    s0 += x[lag + 1] * x[1];
    s1 += x[lag + 1] * x[0];
    s0 += x[lag + 2] * x[2];
    s1 += x[lag + 2] * x[1];
    s2 += x[lag + 2] * x[0];
    for (size_t k = lag + 3; k < n; ++k) {
      const double v = x[k];
      s0 += v * x[k - lag];
      s1 += v * x[k - lag - 1];
      s2 += v * x[k - lag - 2];
      s3 += v * x[k - lag - 3];
    }
    out[lag - first] = s0;
    out[lag + 1 - first] = s1;
    out[lag + 2 - first] = s2;
    out[lag + 3 - first] = s3;
  }
  for (; lag <= last; ++lag) {
    double s = 0;
    for (size_t k = lag; k < n; ++k) s += x[k] * x[k - lag];
    out[lag - first] = s;
  }
}

}  // namespace

void AddAutocorrelationSums(const std::vector<double>& e, std::vector<double>& acf) {
  acf.resize(kAcfMaxLag + 1, 0.0);
  double sums[kAcfMaxLag + 1];
  const size_t last = LastLag(e);
  LagSums(e, 0, last, sums);
  for (size_t lag = 0; lag <= last; ++lag) acf[lag] += sums[lag];
}

double AutocorrelationTimeFromSums(const std::vector<double>& acf) {
  if (acf.empty() || acf[0] <= 0) return 1.0;
  double tau = 1.0;
  for (size_t lag = 1; lag < acf.size(); ++lag) {
    const double rho = acf[lag] / acf[0];
    if (rho <= 0) break;
    tau += 2.0 * rho;
  }
  return tau;
}

namespace {

// The autocorrelation sums of lags [first, last) pooled over `series`: each series' sums are
// added per lag in the series' order, as AddAutocorrelationSums adds them (the same values for
// any number of threads); acf is resized to `last`.
void PooledAutocorrelationSums(const std::vector<std::vector<double>>& series, size_t first, size_t last, int threads,
                               std::vector<double>& acf) {
  const size_t width = last - first;
  std::vector<double> sums(series.size() * width, 0.0);
  ParallelFor(series.size(), threads, [&](size_t i) {
    const size_t top = std::min(last - 1, LastLag(series[i]));
    if (top >= first) LagSums(series[i], first, top, &sums[i * width]);
  });
  acf.resize(last, 0.0);
  for (size_t i = 0; i < series.size(); ++i)
    for (size_t lag = first; lag < last && lag <= LastLag(series[i]); ++lag) acf[lag] += sums[i * width + lag - first];
}

}  // namespace

double IntegratedAutocorrelationTime(const std::vector<std::vector<double>>& residuals_by_chunk, int threads) {
  // Only the lags up to the first non-positive autocorrelation count: they are summed in blocks
  // of growing width until one has turned up (or every lag to kAcfMaxLag is summed). Every lag
  // summed has the value the full sums would give it, so the time is theirs.
  std::vector<double> acf;
  size_t done = 0;
  for (size_t width = 16; done <= kAcfMaxLag; width *= 2) {
    const size_t last = std::min(kAcfMaxLag + 1, done + width);
    PooledAutocorrelationSums(residuals_by_chunk, done, last, threads, acf);
    done = last;
    if (!(acf[0] > 0)) break;
    bool turned = false;
    for (size_t lag = 1; lag < done && !turned; ++lag) turned = acf[lag] / acf[0] <= 0;
    if (turned) break;
  }
  return AutocorrelationTimeFromSums(acf);
}

double ResidualNoiseLevel(const std::vector<std::vector<double>>& residuals_by_chunk, int threads) {
  double rss = 0;
  size_t n = 0;
  for (const auto& e : residuals_by_chunk) {
    for (double x : e) rss += x * x;
    n += e.size();
  }
  return n ? rss / static_cast<double>(n) * IntegratedAutocorrelationTime(residuals_by_chunk, threads) : 0.0;
}

size_t BurnInSamples(const Chunk& c, double burn_in_s) {
  return static_cast<size_t>(std::ceil(burn_in_s / c.dt_s));
}

std::vector<float> EstimateBank(const stats::Segment& seg, double tau_s) {
  std::vector<float> g;
  if (!seg.has_yaw_rate || seg.samples.empty()) return g;
  const size_t n = seg.samples.size();
  std::vector<double> x(n);
  for (size_t k = 0; k < n; ++k) {
    const auto& s = seg.samples[k];
    if (!std::isfinite(s.yaw_rate_radps)) return g;  // a gap in the yaw rate: a_y alone
    x[k] = static_cast<double>(s.speed_mps) * s.yaw_rate_radps - s.lat_accel_mps2;
  }
  const double a = seg.dt_s / (tau_s + seg.dt_s);
  for (size_t k = 1; k < n; ++k) x[k] = x[k - 1] + a * (x[k] - x[k - 1]);
  for (size_t k = n - 1; k-- > 0;) x[k] = x[k + 1] + a * (x[k] - x[k + 1]);
  g.assign(x.begin(), x.end());
  return g;
}

std::vector<Chunk> MakeChunks(const SegmentList& segments, double chunk_s, double burn_in_s,
                              const DriveOverrides& drive_values) {
  std::vector<Chunk> chunks;
  for (const stats::Segment* seg : segments) {
    if (seg == nullptr || seg->samples.empty()) continue;
    const auto bank = std::make_shared<const std::vector<float>>(EstimateBank(*seg));
    const size_t per = std::max<size_t>(1, static_cast<size_t>(std::lround(chunk_s / seg->dt_s)));
    const size_t total = seg->samples.size();
    size_t start = 0;
    while (start < total) {
      size_t n = std::min(per, total - start);
      if (total - (start + n) < per / 2) n = total - start;  // fold a short tail into this chunk
      Chunk c{seg->samples.data() + start, n, seg->dt_s, seg->drive_id, nullptr, {}};
      if (const auto it = drive_values.find(seg->drive_id); it != drive_values.end()) c.drive_params = it->second;
      if (!bank->empty()) {
        c.bank = std::make_shared<const std::vector<float>>(bank->begin() + static_cast<long>(start),
                                                            bank->begin() + static_cast<long>(start + n));
      }
      if (n > BurnInSamples(c, burn_in_s) + 1) chunks.push_back(c);
      start += n;
    }
  }
  return chunks;
}

// The current model's parameter vector re-laid out for a larger model: shared parameters by
// name, new effects at their neutral value.
std::vector<double> Extend(const model::ModelSpec& from, const std::vector<double>& values, const model::ModelSpec& to) {
  std::map<std::string, double> by_name;
  for (int i = 0; i < from.num_params(); ++i) by_name[from.param_name(i)] = values[static_cast<size_t>(i)];
  std::vector<double> out(static_cast<size_t>(to.num_params()));
  for (int i = 0; i < to.num_params(); ++i) {
    const auto it = by_name.find(to.param_name(i));
    out[static_cast<size_t>(i)] = it != by_name.end() ? it->second : to.effect_param(i)->neutral;
  }
  return out;
}

SegmentList Pointers(const std::vector<stats::Segment>& segments) {
  SegmentList out;
  for (const auto& s : segments) out.push_back(&s);
  return out;
}

void EvaluateChunk(const Chunk& chunk, size_t burn, double wheelbase_m, const model::ModelSpec& spec,
                   const std::vector<double>& params, std::vector<double>& residuals, std::vector<double>& jacobian,
                   bool with_yaw_rate) {
  const std::vector<double> ones(params.size(), 1.0);
  auto cost = MakeChunkCost(chunk, burn, wheelbase_m, spec, ones,
                            std::make_shared<const OutputWeights>(OutputWeights{1.0, with_yaw_rate ? 1.0 : 0.0}));
  const int m = cost->num_residuals();
  residuals.assign(static_cast<size_t>(m), 0.0);
  jacobian.assign(static_cast<size_t>(m) * params.size(), 0.0);
  const double* pp[] = {params.data()};
  double* jj[] = {jacobian.data()};
  cost->Evaluate(pp, residuals.data(), jj);
}

}  // namespace ndsid::identify
