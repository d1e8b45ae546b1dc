// The simulated driver: a speed plan from limits, curves (the driver's comfortable lateral
// acceleration) and stops; steering from an imperfect internal model of the car (wrong belief
// of EG and is) with curvature preview, pure-pursuit feedback on lateral offset and heading
// error relative to the road, a neuromuscular lag and correction noise.
#pragma once

#include <vector>

#include "ndsid/config/simulation_config.h"
#include "ndsid/sim/random.h"
#include "ndsid/sim/road.h"

namespace ndsid::sim {

struct DriverProfile {
  int id = 0;
  double speed_factor = 1.0;            // desired speed / limit
  double lat_accel_comfort_mps2 = 2.2;  // comfortable |a_y| in curves at low speed
  double accel_mps2 = 1.5;              // comfortable acceleration
  double decel_mps2 = 1.8;              // comfortable braking
  double preview_s = 0.25;              // curvature feed-forward preview time
  double lookahead_s = 1.1;             // feedback look-ahead time (pure pursuit)
  double lookahead_min_m = 5.0;
  double neuromuscular_tau_s = 0.15;    // lag of the hands on the wheel
  double steer_noise_rad = 0.017;       // correction noise at the steering wheel (OU std)
  double steer_noise_tau_s = 0.8;
  double speed_noise = 0.03;            // relative OU modulation of the desired speed
  double belief_eg_factor = 1.0;        // driver's internal EG / true EG
  double belief_is_factor = 1.0;        // driver's internal is / true is
};

std::vector<DriverProfile> MakeDrivers(const config::SimDrivers& cfg, Rng& rng);

// The speed plan along the road [m/s on the road grid]: min(limit * factor, curve speed),
// zero at stops, forward pass with the comfortable acceleration (power-limited), backward pass
// with the comfortable deceleration.
std::vector<double> PlanSpeed(const Road& road, const DriverProfile& driver);

// Comfortable lateral acceleration at speed v: a0 * (1 - 0.4 min(1, v/40 m/s)).
double ComfortLatAccel(const DriverProfile& driver, double speed_mps);

}  // namespace ndsid::sim
