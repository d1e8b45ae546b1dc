// The default parameter box from physics (parameter_box.h): published parameters of vehicles of
// very different classes lie inside the box made from their wheelbase and mass alone, with
// room to spare, so that the box is never the answer for a real car; the axle loads narrow lv.
#include "ndsid/config/parameter_box.h"

#include <gtest/gtest.h>

#include <regex>
#include <string>

#include "minimal_config.h"

namespace ndsid::config {
namespace {

struct Published {
  std::string what;
  double l, m;          // wheelbase [m], mass [kg]
  double Jz, cv, ch, lv, is;
};

// Sources: the study's C-Max box centre (physics.md §1); the Berkeley Genesis research car's
// simulator values (lf 1.5213 m, Iz 5520 kg m^2, 2 x 76.4 / 2 x 134.9 kN/rad, ratio 13.9..15.87);
// a 1964 Ferrari 250 LM (982 kg, lf 1.33 m of 2.40 m, ratio ~13.3; Jz, cv, ch from its class);
// a 3.5 t panel van and a city car of textbook values (Schramm, Hiller, Bardini: Vehicle
// Dynamics, ch. 10), a 700 kg low-speed utility EV.
const Published kVehicles[] = {
    {"C-Max (study)", 2.648, 1900, 2700, 77500, 122500, 1.15, 14.75},
    {"Genesis sedan", 3.02, 2303, 5520, 152838, 269702, 1.5213, 13.9},
    {"Ferrari 250 LM", 2.40, 982, 1100, 60000, 90000, 1.33, 13.3},
    {"panel van 3.5 t", 3.665, 3500, 9000, 180000, 260000, 1.70, 18.0},
    {"city car", 2.34, 950, 1000, 55000, 70000, 0.95, 16.0},
    {"utility EV", 1.90, 700, 450, 30000, 40000, 0.90, 12.0},
};

void ExpectInside(const ParameterSpec& p, double value, const std::string& what) {
  // At least 10 % of the value away from either bound.
  EXPECT_GT(value, p.lower * 1.1) << what;
  EXPECT_LT(value, p.upper / 1.1) << what;
  EXPECT_GE(p.initial, p.lower) << what;
  EXPECT_LE(p.initial, p.upper) << what;
}

TEST(PhysicalParameterBox, PublishedVehiclesOfEveryClassLieInsideTheirBox) {
  for (const Published& v : kVehicles) {
    const auto box = PhysicalParameterBox(VehicleConfig{.name = v.what, .wheelbase_m = v.l, .mass_kg = v.m});
    EXPECT_TRUE(box[0].fixed);
    EXPECT_EQ(box[0].initial, v.m);
    ExpectInside(box[1], v.Jz, v.what + " Jz");
    ExpectInside(box[2], v.cv, v.what + " cv");
    ExpectInside(box[3], v.ch, v.what + " ch");
    ExpectInside(box[4], v.lv, v.what + " lv");
    ExpectInside(box[5], v.is, v.what + " is");
  }
}

TEST(PhysicalParameterBox, AxleLoadsCentreAndNarrowLv) {
  VehicleConfig v{.name = "x", .wheelbase_m = 2.8, .mass_kg = 1600};
  const auto wide = PhysicalParameterBox(v);
  v.front_axle_load_kg = 960;  // 60 % front: lv = 0.4 l
  v.rear_axle_load_kg = 640;
  const auto narrow = PhysicalParameterBox(v);
  EXPECT_NEAR(narrow[4].initial, 0.4 * 2.8, 1e-12);
  EXPECT_NEAR(narrow[4].upper - narrow[4].lower, 2 * 0.08 * 2.8, 1e-12);
  EXPECT_LT(narrow[4].upper - narrow[4].lower, wide[4].upper - wide[4].lower);
  EXPECT_LT(narrow[1].upper - narrow[1].lower, wide[1].upper - wide[1].lower);
}

TEST(PhysicalParameterBox, TheStartIsAMildlyUndersteeringCar) {
  // EG = m/l (lh/cv - lv/ch) at the initial values: about 1.6 deg/g whatever the car.
  for (const Published& v : kVehicles) {
    const auto b = PhysicalParameterBox(VehicleConfig{.name = v.what, .wheelbase_m = v.l, .mass_kg = v.m});
    const double lv = b[4].initial, lh = v.l - lv;
    const double eg = v.m / v.l * (lh / b[2].initial - lv / b[3].initial);
    EXPECT_NEAR(eg * 9.81 * 180 / M_PI, 1.59, 0.01) << v.what;
  }
}

// A bus that carries the road wheels' angle: every published car's ratio of road-wheel to
// road-wheel angle (1) lies inside the box, the steering wheel's (13..18) outside it; the checks'
// defaults follow, and a user's own values win.
TEST(PhysicalParameterBox, RoadWheelAngleCentresTheSteerRatioOnOne) {
  for (const Published& v : kVehicles) {
    const VehicleConfig road{.name = v.what, .wheelbase_m = v.l, .mass_kg = v.m, .road_wheel_angle = true};
    const auto box = PhysicalParameterBox(road);
    ExpectInside(box[5], 1.0, v.what + " is of a road-wheel angle");
    EXPECT_EQ(box[5].initial, 1.0) << v.what;
    EXPECT_GT(v.is, box[5].upper) << v.what;
    const auto wheel = PhysicalParameterBox(VehicleConfig{.name = v.what, .wheelbase_m = v.l, .mass_kg = v.m});
    for (int i = 0; i < 5; ++i) EXPECT_EQ(box[i].lower, wheel[i].lower) << v.what << " parameter " << i;
  }
  using testing::kMinimal;
  const std::string road = std::regex_replace(kMinimal, std::regex("mass_kg: 1500\\}"), "mass_kg: 1500, steering_angle_at: road_wheels}");
  ASSERT_NE(road, kMinimal);
  const Config c = ParseConfig(road, "car.yaml");
  EXPECT_TRUE(c.vehicle.road_wheel_angle);
  EXPECT_EQ(c.identification.params[5].initial, 1.0);
  EXPECT_EQ(c.plausibility.steer_ratio_min, PlausibilityConfig::kRoadWheelSteerRatioMin);
  EXPECT_EQ(c.plausibility.steer_ratio_max, PlausibilityConfig::kRoadWheelSteerRatioMax);
  EXPECT_NEAR(c.gate.quasi_steady_max_steer_rate_radps, GateConfig{}.quasi_steady_max_steer_rate_radps / 15, 1e-12);
  const Config own = ParseConfig(road + "plausibility: {steer_ratio_min: 0.9, steer_ratio_max: 1.2}\ngate: {quasi_steady_max_steer_rate_radps: 0.01}\n", "car.yaml");
  EXPECT_EQ(own.plausibility.steer_ratio_min, 0.9);
  EXPECT_EQ(own.plausibility.steer_ratio_max, 1.2);
  EXPECT_EQ(own.gate.quasi_steady_max_steer_rate_radps, 0.01);
  const Config wheel = ParseConfig(kMinimal, "car.yaml");
  EXPECT_FALSE(wheel.vehicle.road_wheel_angle);
  EXPECT_EQ(wheel.plausibility.steer_ratio_min, PlausibilityConfig{}.steer_ratio_min);
  const std::string bad = testing::ErrorOf(std::regex_replace(kMinimal, std::regex("mass_kg: 1500\\}"), "mass_kg: 1500, steering_angle_at: wheels}"));
  EXPECT_NE(bad.find("vehicle.steering_angle_at"), std::string::npos) << bad;
  EXPECT_NE(bad.find("'road_wheels'"), std::string::npos) << bad;
}

TEST(PhysicalParameterBox, NeedsWheelbaseAndMass) {
  EXPECT_THROW(PhysicalParameterBox(VehicleConfig{.name = "x", .wheelbase_m = 0, .mass_kg = 1500}), Error);
  EXPECT_THROW(PhysicalParameterBox(VehicleConfig{.name = "x", .wheelbase_m = 2.7, .mass_kg = 0}), Error);
}

}  // namespace
}  // namespace ndsid::config
