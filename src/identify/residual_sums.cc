#include "residual_sums.h"

#include <algorithm>
#include <cmath>

#include "parallel.h"

namespace ndsid::identify {

void AddSums(const std::vector<double>& x, std::vector<double>& pooled, double factor) {
  pooled.resize(kAcfMaxLag + 1, 0.0);
  for (size_t k = 0; k < x.size() && k < pooled.size(); ++k) pooled[k] += factor * x[k];
}

void Linearize(LinearizedChunk& lc, const std::vector<double>& theta, const std::vector<double>& e,
               const Eigen::Ref<const RowMajorMatrix>& J, const Eigen::MatrixXd& jtj, const Eigen::VectorXd& score, size_t n_a,
               const OutputWeights& weights, bool two_outputs, bool with_acf) {
  const int np = static_cast<int>(theta.size());
  const auto split = e.begin() + static_cast<long>(n_a);
  lc = LinearizedChunk{};
  lc.theta = theta;
  lc.jtj.resize(static_cast<size_t>(np) * np);
  Eigen::Map<RowMajorMatrix>(lc.jtj.data(), np, np) = jtj;
  lc.score.resize(static_cast<size_t>(np));
  Eigen::Map<Eigen::VectorXd>(lc.score.data(), np) = score;
  lc.rss = Eigen::Map<const Eigen::VectorXd>(e.data(), static_cast<long>(e.size())).squaredNorm();
  lc.n_a_y = static_cast<uint32_t>(n_a);
  lc.n_yaw_rate = static_cast<uint32_t>(e.size() - n_a);
  for (auto it = e.begin(); it != split; ++it) lc.rss_a_y += (*it / weights.a_y) * (*it / weights.a_y);
  for (auto it = split; it != e.end(); ++it) lc.rss_yaw_rate += (*it / weights.yaw_rate) * (*it / weights.yaw_rate);
  if (with_acf) {
    AddAutocorrelationSums(std::vector<double>(e.begin(), split), lc.acf_a_y);
    if (split != e.end()) AddAutocorrelationSums(std::vector<double>(split, e.end()), lc.acf_yaw_rate);
  }
  if (two_outputs) {  // the yaw-rate part (zero for a chunk without one), for re-weighting
    const long nr = static_cast<long>(e.size() - n_a);
    const auto Jr = J.bottomRows(nr);
    lc.jtj_yaw_rate.resize(static_cast<size_t>(np) * np);
    Eigen::Map<RowMajorMatrix>(lc.jtj_yaw_rate.data(), np, np) = Jr.transpose() * Jr;
    lc.score_yaw_rate.resize(static_cast<size_t>(np));
    Eigen::Map<Eigen::VectorXd>(lc.score_yaw_rate.data(), np) =
        Jr.transpose() * Eigen::Map<const Eigen::VectorXd>(e.data() + n_a, nr);
  }
}

ErrorSums SimulatedErrorSums(const model::ModelSpec& spec, double wheelbase_m, const std::vector<Chunk>& chunks,
                             const std::vector<double>& params, double burn_in_s, bool yaw_rate, int threads) {
  std::vector<ErrorSums> per_chunk(chunks.size());
  ParallelFor(chunks.size(), threads, [&](size_t i) {
    const Chunk& c = chunks[i];
    const bool yaw = yaw_rate && c.has_yaw_rate();
    std::vector<double> a_y(c.n), yr(yaw ? c.n : 0);
    model::SimulateModel(spec, c.ParamsFor(params).data(), wheelbase_m, c.Inputs(), a_y.data(), nullptr,
                         yaw ? yr.data() : nullptr);
    ErrorSums& x = per_chunk[i];
    for (size_t k = BurnInSamples(c, burn_in_s); k < c.n; ++k) {
      const double e = c.samples[k].lat_accel_mps2 - a_y[k];
      x.a += e * e;
      ++x.na;
      if (!yaw) continue;
      const double er = c.samples[k].yaw_rate_radps - yr[k];
      x.r += er * er;
      ++x.nr;
    }
  });
  ErrorSums total;
  for (const ErrorSums& x : per_chunk) {
    total.a += x.a;
    total.r += x.r;
    total.na += x.na;
    total.nr += x.nr;
  }
  return total;
}

double RootMean(double sum, size_t n) { return n ? std::sqrt(sum / static_cast<double>(n)) : -1.0; }

double AddSeriesSums(const std::vector<std::vector<double>>& series, std::vector<double>& acf) {
  double n = 0;
  for (const auto& e : series) {
    AddAutocorrelationSums(e, acf);
    n += static_cast<double>(e.size());
  }
  return n;
}

double LevelOfSums(const std::vector<double>& acf, double n) {
  return n > 0 && !acf.empty() ? acf[0] / n * AutocorrelationTimeFromSums(acf) : 0.0;
}

double SeriesFloor(const std::vector<std::vector<double>>& series, double weight) {
  double d2 = 0;
  size_t n = 0;
  for (const auto& e : series) {
    for (size_t k = 1; k < e.size(); ++k) d2 += (e[k] - e[k - 1]) * (e[k] - e[k - 1]);
    n += e.size() > 1 ? e.size() - 1 : 0;
  }
  return n && weight > 0 ? std::sqrt(d2 / (2.0 * static_cast<double>(n))) / weight : -1.0;
}
double SumsFloor(const std::vector<double>& acf, double n, double weight) {
  if (acf.size() < 2 || !(n > 0) || !(weight > 0)) return -1.0;
  return std::sqrt(std::max(0.0, acf[0] - acf[1]) / n) / weight;
}

}  // namespace ndsid::identify
