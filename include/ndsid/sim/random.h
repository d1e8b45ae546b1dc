// Portable random numbers for the simulator: std::mt19937_64 (its output sequence is fixed by
// the standard) with our own uniform and Box-Muller normal, so a seed gives the same drives on
// every standard library (std::normal_distribution is implementation-defined).
#pragma once

#include <cmath>
#include <cstdint>
#include <random>

namespace ndsid::sim {

// splitmix64: derives independent seeds for the streams (road, driver, sensors, ...).
inline uint64_t MixSeed(uint64_t a, uint64_t b) {
  uint64_t z = a + 0x9E3779B97F4A7C15ull * (b + 1);
  z = (z ^ (z >> 30)) * 0xBF58476D1CE4E5B9ull;
  z = (z ^ (z >> 27)) * 0x94D049BB133111EBull;
  return z ^ (z >> 31);
}

class Rng {
 public:
  explicit Rng(uint64_t seed) : engine_(seed) {}

  double Uniform() { return static_cast<double>(engine_() >> 11) * 0x1.0p-53; }  // [0, 1)
  double Uniform(double lo, double hi) { return lo + (hi - lo) * Uniform(); }
  bool Bernoulli(double p) { return Uniform() < p; }
  int Index(int n) { return static_cast<int>(Uniform() * n); }  // 0..n-1
  double Sign() { return Uniform() < 0.5 ? -1.0 : 1.0; }
  double LogUniform(double lo, double hi) { return lo * std::exp(std::log(hi / lo) * Uniform()); }

  // Standard normal by Box-Muller (both values used).
  double Normal() {
    if (has_spare_) {
      has_spare_ = false;
      return spare_;
    }
    double u1 = Uniform();
    while (u1 <= 0.0) u1 = Uniform();
    const double u2 = Uniform();
    const double radius = std::sqrt(-2.0 * std::log(u1));
    spare_ = radius * std::sin(2.0 * M_PI * u2);
    has_spare_ = true;
    return radius * std::cos(2.0 * M_PI * u2);
  }
  double Normal(double mean, double sigma) { return mean + sigma * Normal(); }

 private:
  std::mt19937_64 engine_;
  double spare_ = 0.0;
  bool has_spare_ = false;
};

// Ornstein-Uhlenbeck process with stationary standard deviation `sigma` and correlation time
// `tau`, advanced with its exact discretisation (so the statistics do not depend on the step).
class OrnsteinUhlenbeck {
 public:
  OrnsteinUhlenbeck(double sigma, double tau_s) : sigma_(sigma), tau_s_(tau_s) {}
  void Reset(Rng& rng) { x_ = sigma_ * rng.Normal(); }
  double Step(Rng& rng, double dt_s) {
    const double a = std::exp(-dt_s / tau_s_);
    x_ = a * x_ + sigma_ * std::sqrt(1.0 - a * a) * rng.Normal();
    return x_;
  }
  double value() const { return x_; }

 private:
  double sigma_;
  double tau_s_;
  double x_ = 0.0;
};

}  // namespace ndsid::sim
