// The road of one drive as the driver sees it, in curvilinear coordinates along the lane
// centre: curvature (straights, clothoid transitions, arcs, junction turns), speed limit, bank
// (random crossfall + optional superelevation into curves), the target lateral offset (lane
// changes, evasive manoeuvres) and the stops (traffic lights, junctions, the end of the drive).
// Sampled on a fixed grid in s and interpolated linearly.
#pragma once

#include <cstdint>
#include <vector>

#include "ndsid/config/simulation_config.h"
#include "ndsid/sim/random.h"

namespace ndsid::sim {

enum class RoadType : uint8_t { kUrban = 0, kRural = 1, kMotorway = 2 };
const char* RoadTypeName(RoadType type);

struct StopPoint {
  double s_m = 0.0;      // where the front of the car stops
  double dwell_s = 0.0;  // standstill time
};

class Road {
 public:
  static constexpr double kGridStep_m = 0.5;

  double length_m() const { return (static_cast<double>(curvature_.size()) - 1.0) * kGridStep_m; }
  // Interpolated lookups; s is clamped to [0, length].
  double Curvature(double s_m) const { return Lerp(curvature_, s_m); }        // 1/m, + left
  double SpeedLimit(double s_m) const { return Lerp(speed_limit_mps_, s_m); }
  double Bank(double s_m) const { return Lerp(bank_rad_, s_m); }             // ISO roll of the road surface
  double Crossfall(double s_m) const { return Lerp(crossfall_rad_, s_m); }   // random part of Bank
  double LaneOffset(double s_m) const;       // target lateral offset e_ref(s) [m, + left]
  double LaneOffsetSlope(double s_m) const;  // de_ref/ds
  double LaneOffsetCurvature(double s_m) const;  // d2e_ref/ds2 [1/m]
  RoadType Type(double s_m) const;
  const std::vector<StopPoint>& stops() const { return stops_; }
  const std::vector<double>& curvature_grid() const { return curvature_; }
  const std::vector<double>& speed_limit_grid() const { return speed_limit_mps_; }
  int evasive_count() const { return evasive_count_; }
  double TypeLength_m(RoadType type) const;

 private:
  friend class RoadBuilder;
  struct Ramp {  // e_ref += height * (1 - cos(pi x))/2, x = (s - s0)/length in [0, 1]
    double s0_m, length_m, height_m;
  };
  double Lerp(const std::vector<double>& grid, double s_m) const;

  std::vector<double> curvature_;
  std::vector<double> speed_limit_mps_;
  std::vector<double> bank_rad_;
  std::vector<double> crossfall_rad_;
  std::vector<uint8_t> type_;
  std::vector<Ramp> ramps_;  // sorted by s0
  std::vector<StopPoint> stops_;
  int evasive_count_ = 0;
};

// Generates the road of a drive of about `length_m`: urban stretches at both ends, rural and
// motorway in between for longer drives (see docs/simulator.md for the element statistics).
Road GenerateRoad(double length_m, const config::SimRoad& road_config, double superelevation_pct, Rng& rng);

}  // namespace ndsid::sim
