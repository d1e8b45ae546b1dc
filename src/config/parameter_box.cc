#include "ndsid/config/parameter_box.h"

#include <algorithm>

#include "ndsid/common/error.h"

namespace ndsid::config {
namespace {
constexpr double kGravity_mps2 = 9.81;
}  // namespace

std::array<ParameterSpec, 6> PhysicalParameterBox(const VehicleConfig& v, const PhysicalBoxLimits& q) {
  const double l = v.wheelbase_m, m = v.mass_kg;
  if (!(l > 0) || !(m > 0)) throw Error("the parameter box needs vehicle.wheelbase_m and vehicle.mass_kg");
  // lv / l: from the axle loads (the rear axle's share of the weight), else the wide range.
  double s_min = q.cg_share_min, s_max = q.cg_share_max, s0 = q.cg_share_typical;
  if (v.front_axle_load_kg > 0 && v.rear_axle_load_kg > 0) {
    s0 = v.rear_axle_load_kg / (v.front_axle_load_kg + v.rear_axle_load_kg);
    s_min = std::max(0.05, s0 - q.cg_share_tolerance);
    s_max = std::min(0.95, s0 + q.cg_share_tolerance);
  }
  // lv lh / l^2 = s (1 - s) over [s_min, s_max]: smallest at an end, largest nearest s = 0.5.
  const auto lvlh = [](double s) { return s * (1 - s); };
  const double lvlh_min = std::min(lvlh(s_min), lvlh(s_max));
  const double lvlh_max = lvlh(std::clamp(0.5, s_min, s_max));
  const double mg = m * kGravity_mps2;

  std::array<ParameterSpec, 6> p{};
  p[0] = {0.8 * m, 1.25 * m, m, true};  // fixed to the data sheet; the box where it is freed
  p[1] = {q.dynamic_index_min * m * lvlh_min * l * l, q.dynamic_index_max * m * lvlh_max * l * l,
          q.dynamic_index_typical * m * lvlh(s0) * l * l, false};
  p[2] = {q.cornering_coefficient_min * mg * (1 - s_max), q.cornering_coefficient_max * mg * (1 - s_min),
          q.cornering_coefficient_front_typical * mg * (1 - s0), false};
  p[3] = {q.cornering_coefficient_min * mg * s_min, q.cornering_coefficient_max * mg * s_max,
          q.cornering_coefficient_rear_typical * mg * s0, false};
  p[4] = {s_min * l, s_max * l, s0 * l, false};
  p[5] = v.road_wheel_angle ? ParameterSpec{q.road_wheel_steer_ratio_min, q.road_wheel_steer_ratio_max, 1.0, false}
                             : ParameterSpec{q.steer_ratio_min, q.steer_ratio_max, q.steer_ratio_typical, false};
  for (ParameterSpec& x : p) x.initial = std::clamp(x.initial, x.lower, x.upper);
  return p;
}

}  // namespace ndsid::config
