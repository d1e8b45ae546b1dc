// The residual signatures' even shapes and the measured a_y - v r beside them, on synthetic chunks
// whose left and right turns are driven unequally (more and harder turns one way), as on roads
// with right-hand traffic: an odd error then correlates with a_y^2 too, and the even slope must
// not take it.
#include <gtest/gtest.h>

#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <vector>

#include "signatures.h"

namespace ndsid::discover {
namespace {

constexpr double kL = 2.7, kEg = 0.004;  // wheelbase [m], EG [rad/(m/s^2)]

struct Drive {
  std::vector<std::vector<stats::SegmentSample>> chunks;
};

// Chunks of 10 s at 20 Hz: each a turn one way or the other (60 % left, the right ones 1.6x harder),
// a_y = v r (steady), the steering from the single-track steady state.
Drive Turns(unsigned seed, int n_chunks) {
  std::mt19937 rng(seed);
  std::uniform_real_distribution<double> u(0.0, 1.0);
  Drive d;
  for (int c = 0; c < n_chunks; ++c) {
    const double v = 8 + 22 * u(rng);
    const double side = u(rng) < 0.6 ? 1.0 : -1.6;
    const double peak = side * (0.5 + 2.0 * u(rng));
    std::vector<stats::SegmentSample> s(200);
    for (size_t k = 0; k < s.size(); ++k) {
      const double a = peak * std::sin(M_PI * double(k) / double(s.size()));
      const double delta = a * (kL + kEg * v * v) / (v * v);
      s[k] = {float(15.0 * delta), float(v), float(a), float(a / v), 0.0f, 0.0f};
    }
    d.chunks.push_back(std::move(s));
  }
  return d;
}

struct Result {
  SignatureCorrelation a_y2, kin_a_y2;
};

// Residual e = k2 a^2 + odd * a^3 + noise; the accelerometer reads the even error too when
// `in_accelerometer` (a_y,meas - v r = k2 a^2), else a_y and v r agree.
Result Score(const Drive& d, double k2, double odd, bool in_accelerometer, unsigned seed) {
  std::mt19937 rng(seed);
  std::normal_distribution<double> noise(0.0, 0.03);
  SignatureSums sums(kL, kEg);
  auto bank = std::make_shared<const std::vector<float>>(200, 0.0f);  // a yaw rate on every sample
  for (auto samples : d.chunks) {
    std::vector<double> e(samples.size());
    for (size_t k = 0; k < samples.size(); ++k) {
      const double a = samples[k].lat_accel_mps2;
      e[k] = k2 * a * a + odd * a * a * a + noise(rng);
      if (in_accelerometer) samples[k].lat_accel_mps2 = float(a + k2 * a * a);
    }
    identify::Chunk c{samples.data(), samples.size(), 0.05, 1, bank, {}};
    for (double& x : e) x *= 2.0;  // the residuals as scored: weighted (two outputs stacked)
    sums.AddChunk(c, 0, e, samples.size(), 2.0);
  }
  auto find = [](const std::vector<SignatureCorrelation>& v, const std::string& key) {
    for (const auto& s : v)
      if (s.key == key) return s;
    ADD_FAILURE() << "no signature " << key;
    return SignatureCorrelation{};
  };
  return {find(sums.Correlations(), "a_y2"), find(sums.KinematicCorrelations(), "a_y2")};
}

TEST(SignatureSums, EvenSlopeFindsAQuadraticErrorBesideAnOddOneWithUnequalTurns) {
  // Catches an even slope that takes the odd a^3 error (the turns are unequal, so a^3 and a^2
  // correlate), or a wrong clustered standard error: 4 seeds, both signs, within 3 sigma.
  for (unsigned seed : {1u, 2u, 3u, 4u}) {
    const Drive d = Turns(seed, 120);
    for (double k2 : {0.015, -0.02}) {
      const Result r = Score(d, k2, 0.004, false, seed + 10);
      EXPECT_NEAR(r.a_y2.slope, 2.0 * k2, 3 * r.a_y2.slope_se) << "seed " << seed;  // as scored
      EXPECT_LT(r.a_y2.slope_se, 0.2 * std::abs(k2));
      // With the odd error alone the even slope is zero within its noise.
      const Result odd = Score(d, 0.0, 0.004, false, seed + 20);
      EXPECT_LT(std::abs(odd.a_y2.slope), 3 * odd.a_y2.slope_se + 1e-9) << "seed " << seed;
    }
  }
}

TEST(SignatureSums, MeasuredAyMinusVrCarriesAnAccelerometersEvenErrorAndNotTheCars) {
  // Catches a kinematic residual built from the model instead of the measurements, or one whose
  // even slope is not on the scale of the residual's (the verdict reads their ratio: 1 for the
  // accelerometer, 0 for the steering).
  for (unsigned seed : {5u, 6u, 7u}) {
    const Drive d = Turns(seed, 120);
    const Result sensor = Score(d, 0.02, 0.0, true, seed);
    EXPECT_NEAR(sensor.kin_a_y2.slope / sensor.a_y2.slope, 1.0, 0.1) << "seed " << seed;
    const Result car = Score(d, 0.02, 0.0, false, seed);
    EXPECT_NEAR(car.kin_a_y2.slope / car.a_y2.slope, 0.0, 0.1) << "seed " << seed;
  }
}

}  // namespace
}  // namespace ndsid::discover
