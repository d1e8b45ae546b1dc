// The residuals' noise level sigma^2 tau and autocorrelation time: summed only up to the lag
// that decides tau, spread over threads, and still exactly the full sums' values; and a fit whose
// passes over the chunks run on several threads gives the single thread's result.
#include <gtest/gtest.h>

#include <cmath>
#include <random>
#include <vector>

#include "ndsid/identify/chunks.h"
#include "ndsid/identify/identifier.h"
#include "synthetic_segments.h"

namespace ndsid::identify {
namespace {

namespace t = ndsid::testing;

// Series of AR(1) noise with coefficient phi, of mixed lengths (some shorter than the lags
// summed, one empty).
std::vector<std::vector<double>> Ar1Series(double phi, uint64_t seed) {
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n(0.0, 1.0);
  std::uniform_int_distribution<size_t> len(0, 4000);
  std::vector<std::vector<double>> out;
  for (int c = 0; c < 40; ++c) {
    std::vector<double> e(c == 7 ? 0 : (c % 5 == 0 ? len(rng) % 100 : len(rng)));
    double x = n(rng);
    for (double& v : e) v = x = phi * x + n(rng);
    out.push_back(std::move(e));
  }
  return out;
}

double FullSumsTime(const std::vector<std::vector<double>>& series) {
  std::vector<double> acf;
  for (const auto& e : series) AddAutocorrelationSums(e, acf);
  return AutocorrelationTimeFromSums(acf);
}

// Catches: a lazy sum that stops before the deciding lag, sums a lag differently from
// AddAutocorrelationSums, or whose result depends on the number of threads. The correlation
// ranges from none to one that stays positive past every lag summed (tau from all 250).
TEST(NoiseLevel, LazyAutocorrelationTimeEqualsTheFullSums) {
  for (const double phi : {0.0, 0.5, 0.9, 0.99, 0.999}) {
    for (const uint64_t seed : {1u, 2u, 3u}) {
      const auto series = Ar1Series(phi, seed);
      const double full = FullSumsTime(series);
      for (const int threads : {1, 2, 3}) {
        EXPECT_EQ(IntegratedAutocorrelationTime(series, threads), full) << "phi " << phi << " threads " << threads;
      }
      EXPECT_EQ(ResidualNoiseLevel(series, 2), ResidualNoiseLevel(series, 1)) << "phi " << phi;
      if (phi == 0.0) {
        EXPECT_LT(full, 1.5);
      }
      if (phi == 0.9) {  // AR(1): tau = (1 + phi) / (1 - phi) = 19
        EXPECT_NEAR(full, (1 + phi) / (1 - phi), 0.15 * (1 + phi) / (1 - phi));
      }
    }
  }
  EXPECT_EQ(IntegratedAutocorrelationTime({}, 2), 1.0);
  EXPECT_EQ(ResidualNoiseLevel({{}, {}}, 2), 0.0);
}

// Catches: lag sums that differ from their definition, sum_k e_k e_(k-lag) added in the order
// k = lag, lag + 1, ... (the persisted chunks' sums and a new build's must agree bit for bit), or
// that miss the lags of a series shorter than kAcfMaxLag. Bit-exact comparison.
TEST(NoiseLevel, LagSumsAreTheirDefinitionBitForBit) {
  // Also every length around the four-lag groups' edges (lags summed four at a time from the
  // first: src/identify/chunks.cc): 1..9 samples and around the last lag, 250.
  std::vector<std::vector<double>> edges;
  for (const size_t n : {1, 2, 3, 4, 5, 6, 7, 8, 9, 248, 249, 250, 251, 252, 253, 254, 255}) {
    std::vector<double> e(n);
    for (size_t k = 0; k < n; ++k) e[k] = std::sin(0.37 * static_cast<double>(k * k + 1));
    edges.push_back(std::move(e));
  }
  for (const double phi : {0.0, 0.9, 0.999, -1.0}) {
    for (const auto& e : phi < 0 ? edges : Ar1Series(phi, 5)) {
      std::vector<double> acf;
      AddAutocorrelationSums(e, acf);
      ASSERT_EQ(acf.size(), kAcfMaxLag + 1);
      for (size_t lag = 0; lag <= kAcfMaxLag; ++lag) {
        double s = 0;
        for (size_t k = lag; k < e.size(); ++k) s += e[k] * e[k - lag];
        ASSERT_EQ(acf[lag], s) << "lag " << lag << " of a series of " << e.size();
      }
    }
  }
}

// Catches: a pass over the chunks (output weights, the priors' weight, J'J and scores at the
// optimum, the noise levels) whose sums depend on the thread count or miss a chunk. Two outputs
// with road_bank and gyro_offset, fitted on 1 and on 2 threads.
TEST(NoiseLevel, FitOnTwoThreadsEqualsOneThread) {
  const auto [truth_spec, truth] = t::CrossfallGyroOffsetTruth();
  const auto train = t::SyntheticTwoOutputSegments(truth_spec, truth, 24, 60, 0.05, 0.1 * M_PI / 180.0, 81, 0.2);
  const model::ModelSpec spec = model::ModelSpec::FromNames({"road_bank", "gyro_offset"});
  config::IdentificationConfig cfg = t::DefaultIdentificationConfig();
  cfg.yaw_rate_output = true;
  cfg.threads = 1;
  const IdentificationResult one = Identifier(cfg, t::kWheelbase, spec).Identify(t::Pointers(train), {});
  cfg.threads = 2;
  const IdentificationResult two = Identifier(cfg, t::kWheelbase, spec).Identify(t::Pointers(train), {});
  ASSERT_TRUE(one.valid) << one.reason;
  ASSERT_TRUE(two.valid) << two.reason;
  // Ceres's own evaluation may order its sums by thread; everything of ours is summed in chunk
  // order. So equal to the last digits, not necessarily bit for bit.
  EXPECT_NEAR(two.eg_rad_per_mps2, one.eg_rad_per_mps2, 1e-9 * std::abs(one.eg_rad_per_mps2));
  EXPECT_NEAR(two.eg_se_rad_per_mps2, one.eg_se_rad_per_mps2, 1e-9 * one.eg_se_rad_per_mps2);
  EXPECT_NEAR(two.noise_level_a_y, one.noise_level_a_y, 1e-9 * one.noise_level_a_y);
  EXPECT_NEAR(two.noise_level_yaw_rate, one.noise_level_yaw_rate, 1e-9 * one.noise_level_yaw_rate);
  EXPECT_NEAR(two.rmse_train_mps2, one.rmse_train_mps2, 1e-9 * one.rmse_train_mps2);
  EXPECT_GT(one.noise_level_yaw_rate, 0.0);
}

}  // namespace
}  // namespace ndsid::identify
