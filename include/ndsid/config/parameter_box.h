// The default parameter box of the single-track model for any car, from physics and the vehicle's
// data sheet (docs/configuration.md, "The parameter box"): wide enough for city cars, vans,
// sports cars and low-speed utility vehicles, so that the data, not the box, set the estimate;
// a parameter that still ends on such a bound says the model or the data are wrong, not the box.
//   lv  the CG's distance from the front axle: from the axle loads where given (+- 0.08 l), else
//       0.25..0.75 l (front axle carrying 25..75 % of the weight)
//   Jz  m lv lh times a dynamic index of 0.5..1.6 (cars 0.8..1.2), lv lh taken at its extremes
//   cv  front axle load times a cornering coefficient of 4..30 /rad (snow tyres to slicks);
//   ch  the same for the rear axle
//   is  5..40 (direct racing steering to heavy trucks); 0.5..2 where the steering role is a
//       road-wheel angle (vehicle.steering_angle_at: road_wheels)
// m is fixed to the data sheet. Initial values (and the solver's scaling) are the middle of the
// typical ranges; the fit itself starts from the steady-state regression where it has one.
#pragma once

#include <array>

#include "ndsid/config/config.h"

namespace ndsid::config {

struct PhysicalBoxLimits {
  double cg_share_min = 0.25, cg_share_max = 0.75;  // lv / l without axle loads
  double cg_share_tolerance = 0.08;                 // +- on lv / l with axle loads
  double dynamic_index_min = 0.5, dynamic_index_max = 1.6;  // Jz / (m lv lh)
  double cornering_coefficient_min = 4, cornering_coefficient_max = 30;  // axle stiffness / axle load [1/rad]
  double steer_ratio_min = 5, steer_ratio_max = 40;
  double road_wheel_steer_ratio_min = 0.5, road_wheel_steer_ratio_max = 2;  // a road-wheel angle: about 1
  // Initial values: typical of a passenger car.
  // A mildly understeering car (front 9, rear 12 /rad: EG about 1.6 deg/g).
  double cg_share_typical = 0.45, dynamic_index_typical = 0.95, steer_ratio_typical = 15;
  double cornering_coefficient_front_typical = 9, cornering_coefficient_rear_typical = 12;
};

// The box for p = (m, Jz, cv, ch, lv, is) from wheelbase and mass (and the axle loads where the
// vehicle gives them). Needs wheelbase_m > 0 and mass_kg > 0.
std::array<ParameterSpec, 6> PhysicalParameterBox(const VehicleConfig& vehicle, const PhysicalBoxLimits& limits = {});

}  // namespace ndsid::config
