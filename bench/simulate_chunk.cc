// The model's simulation of one chunk, the fit's innermost loop: SimulateModel over 60 s at
// 50 Hz (3 000 samples, both outputs), in doubles (a cost evaluation) and in 8-wide Jets (a cost
// with its Jacobian). Prints the best per-chunk time over blocks of repetitions, which is steadier
// than the mean on a shared machine; compare builds by running each binary in turn.
//   ndsid_bench_simulate_chunk [EFFECT...]     (default: road_bank gyro_offset, the example config's)
#include <algorithm>
#include <chrono>
#include <cmath>
#include <cstdio>
#include <string>
#include <vector>

#include "ndsid/model/effect.h"
#include "ndsid/model/model_spec.h"
#include "ndsid/model/simulate.h"

namespace {

template <typename Fn>
double BestMilliseconds(Fn&& fn) {
  double best = 1e300;
  for (int block = 0; block < 15; ++block) {
    const auto t0 = std::chrono::steady_clock::now();
    for (int rep = 0; rep < 20; ++rep) fn();
    const auto t1 = std::chrono::steady_clock::now();
    best = std::min(best, std::chrono::duration<double, std::milli>(t1 - t0).count() / 20);
  }
  return best;
}

}  // namespace

int main(int argc, char** argv) {
  using namespace ndsid::model;
  std::vector<std::string> names(argv + 1, argv + argc);
  if (argc == 1) names = {"road_bank", "gyro_offset"};
  const ModelSpec spec = ModelSpec::FromNames(names);
  // Inputs in the interleaved layout of the gated samples: steering, speed, yaw rate.
  const size_t n = 3000;
  const double dt = 0.02;
  std::vector<float> samples(n * 3), bank(n);
  for (size_t k = 0; k < n; ++k) {
    const double t = static_cast<double>(k) * dt;
    samples[k * 3] = static_cast<float>(0.3 * std::sin(0.5 * t) + 0.05 * std::sin(3.1 * t));
    samples[k * 3 + 1] = static_cast<float>(15 + 5 * std::sin(0.05 * t));
    samples[k * 3 + 2] = static_cast<float>(0.1 * std::sin(0.5 * t + 0.3));
    bank[k] = static_cast<float>(0.05 * std::sin(0.01 * t));
  }
  const InputSeries in{samples.data(), samples.data() + 1, 3, n, dt, bank.data(), samples.data() + 2};
  std::vector<double> p = {1900, 2700, 77000, 120000, 1.15, 14.8};
  for (int i = kNumParams; i < spec.num_params(); ++i) p.push_back(spec.effect_param(i)->typical);
  const size_t np = p.size();
  std::vector<SmallJet> pj(np);
  for (size_t i = 0; i < np; ++i) pj[i] = SmallJet(p[i], static_cast<int>(i % kSmallJetSize));
  std::vector<double> a(n), r(n);
  std::vector<SmallJet> aj(n), rj(n);
  double sink = 0;
  const double plain = BestMilliseconds([&] {
    SimulateModel(spec, p.data(), 2.648, in, a.data(), nullptr, r.data());
    sink += a[n - 1];
  });
  const double jets = BestMilliseconds([&] {
    SimulateModel(spec, pj.data(), 2.648, in, aj.data(), nullptr, rj.data());
    sink += aj[n - 1].v[0];
  });
  std::printf("model %s, %zu parameters, %zu samples: doubles %.3f ms, 8-wide Jets %.3f ms per chunk (best of 15 x 20; %g)\n",
              spec.Describe().c_str(), np, n, plain, jets, sink == 0 ? 0.0 : 1.0);
  return 0;
}
