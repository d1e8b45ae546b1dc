#include "ndsid/sim/driver.h"

#include <algorithm>
#include <cmath>

namespace ndsid::sim {

std::vector<DriverProfile> MakeDrivers(const config::SimDrivers& cfg, Rng& rng) {
  std::vector<DriverProfile> drivers;
  for (int i = 0; i < cfg.count; ++i) {
    DriverProfile d;
    d.id = i;
    d.speed_factor = rng.Uniform(0.93, 1.07);
    d.lat_accel_comfort_mps2 = rng.Uniform(cfg.lat_accel_comfort_min_mps2, cfg.lat_accel_comfort_max_mps2);
    d.accel_mps2 = rng.Uniform(1.0, 2.0);
    d.decel_mps2 = rng.Uniform(1.3, 2.3);
    d.preview_s = rng.Uniform(0.15, 0.35);
    d.lookahead_s = rng.Uniform(0.9, 1.4);
    d.lookahead_min_m = rng.Uniform(4.0, 6.0);
    d.neuromuscular_tau_s = rng.Uniform(0.1, 0.2);
    d.steer_noise_rad = cfg.steer_noise_deg * rng.Uniform(0.6, 1.4) * M_PI / 180.0;
    d.steer_noise_tau_s = rng.Uniform(0.5, 1.2);
    d.speed_noise = rng.Uniform(0.02, 0.04);
    const double e = cfg.belief_error_pct / 100.0;
    d.belief_eg_factor = 1.0 + rng.Uniform(-e, e) * 2.0;  // EG is the harder number to know
    d.belief_is_factor = 1.0 + rng.Uniform(-e, e);
    drivers.push_back(d);
  }
  return drivers;
}

double ComfortLatAccel(const DriverProfile& driver, double v) {
  return driver.lat_accel_comfort_mps2 * (1.0 - 0.4 * std::min(1.0, std::fabs(v) / 40.0));
}

std::vector<double> PlanSpeed(const Road& road, const DriverProfile& driver) {
  const double ds = Road::kGridStep_m;
  const auto& kappa = road.curvature_grid();
  const auto& limit = road.speed_limit_grid();
  const size_t n = kappa.size();
  std::vector<double> v(n);
  for (size_t i = 0; i < n; ++i) {
    double vmax = limit[i] * driver.speed_factor;
    const double k = std::fabs(kappa[i]);
    if (k > 1e-6) {  // v = sqrt(a(v)/kappa), a decreasing with v: fixed point
      double vc = std::sqrt(driver.lat_accel_comfort_mps2 / k);
      for (int it = 0; it < 8; ++it) vc = std::sqrt(ComfortLatAccel(driver, vc) / k);
      vmax = std::min(vmax, vc);
    }
    v[i] = vmax;
  }
  for (const auto& stop : road.stops()) {
    const size_t i = std::min(n - 1, static_cast<size_t>(std::lround(stop.s_m / ds)));
    v[i] = 0.0;
  }
  v[0] = 0.0;
  for (size_t i = 0; i + 1 < n; ++i) {  // comfortable, power-limited acceleration
    const double a = std::min(driver.accel_mps2, 25.0 / std::max(v[i], 1.0));
    v[i + 1] = std::min(v[i + 1], std::sqrt(v[i] * v[i] + 2.0 * a * ds));
  }
  for (size_t i = n - 1; i > 0; --i)  // comfortable braking
    v[i - 1] = std::min(v[i - 1], std::sqrt(v[i] * v[i] + 2.0 * driver.decel_mps2 * ds));
  return v;
}

}  // namespace ndsid::sim
