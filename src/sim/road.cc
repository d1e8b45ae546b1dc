// Road generation: elements (straight, clothoid-arc-clothoid curve, junction turn) per road type,
// then crossfall, superelevation, lane changes, evasive manoeuvres and stops on the grid.
#include "ndsid/sim/road.h"

#include <algorithm>
#include <cmath>

namespace ndsid::sim {

const char* RoadTypeName(RoadType type) {
  switch (type) {
    case RoadType::kUrban: return "urban";
    case RoadType::kRural: return "rural";
    case RoadType::kMotorway: return "motorway";
  }
  return "?";
}

double Road::Lerp(const std::vector<double>& grid, double s_m) const {
  const double x = std::clamp(s_m / kGridStep_m, 0.0, static_cast<double>(grid.size() - 1));
  const size_t i = std::min(static_cast<size_t>(x), grid.size() - 2);
  const double f = x - static_cast<double>(i);
  return grid[i] + f * (grid[i + 1] - grid[i]);
}

RoadType Road::Type(double s_m) const {
  const double x = std::clamp(s_m / kGridStep_m, 0.0, static_cast<double>(type_.size() - 1));
  return static_cast<RoadType>(type_[static_cast<size_t>(x)]);
}

double Road::TypeLength_m(RoadType type) const {
  size_t n = 0;
  for (uint8_t t : type_) n += (t == static_cast<uint8_t>(type));
  return static_cast<double>(n) * kGridStep_m;
}

namespace {
// Cosine ramp h(x) = (1 - cos(pi x))/2 on [0, 1] and its derivatives w.r.t. x.
double RampValue(double x) { return x <= 0 ? 0.0 : x >= 1 ? 1.0 : 0.5 * (1.0 - std::cos(M_PI * x)); }
double RampSlope(double x) { return (x <= 0 || x >= 1) ? 0.0 : 0.5 * M_PI * std::sin(M_PI * x); }
double RampCurv(double x) { return (x <= 0 || x >= 1) ? 0.0 : 0.5 * M_PI * M_PI * std::cos(M_PI * x); }
}  // namespace

double Road::LaneOffset(double s_m) const {
  double e = 0.0;
  for (const Ramp& r : ramps_) {
    if (s_m <= r.s0_m) break;
    e += r.height_m * RampValue((s_m - r.s0_m) / r.length_m);
  }
  return e;
}

double Road::LaneOffsetSlope(double s_m) const {
  for (const Ramp& r : ramps_) {
    if (s_m <= r.s0_m) break;
    if (s_m < r.s0_m + r.length_m) return r.height_m / r.length_m * RampSlope((s_m - r.s0_m) / r.length_m);
  }
  return 0.0;
}

double Road::LaneOffsetCurvature(double s_m) const {
  for (const Ramp& r : ramps_) {
    if (s_m <= r.s0_m) break;
    if (s_m < r.s0_m + r.length_m)
      return r.height_m / (r.length_m * r.length_m) * RampCurv((s_m - r.s0_m) / r.length_m);
  }
  return 0.0;
}

// Builds the curvature profile as piecewise-linear knots, with per-element attributes.
class RoadBuilder {
 public:
  explicit RoadBuilder(Rng& rng) : rng_(rng) {}

  void Straight(double length_m, RoadType type, double limit_mps) {
    Segment(length_m, 0.0, 0.0, type, limit_mps, false);
  }
  // Clothoid in (length lc), arc, clothoid out; turn angle = kappa * (arc + lc).
  void Curve(double radius_m, double angle_rad, double lc_m, double sign, RoadType type, double limit_mps,
             bool banked) {
    const double kappa = sign / radius_m;
    lc_m = std::min(lc_m, 0.5 * angle_rad * radius_m);
    const double arc = angle_rad * radius_m - lc_m;
    Segment(lc_m, 0.0, kappa, type, limit_mps, banked);
    Segment(arc, kappa, kappa, type, limit_mps, banked);
    Segment(lc_m, kappa, 0.0, type, limit_mps, banked);
  }
  void Stop(double dwell_s) { stops_.push_back({s_, dwell_s}); }
  double s() const { return s_; }

  Road Finish(const config::SimRoad& cfg, double superelevation_pct) {
    Road road;
    const double ds = Road::kGridStep_m;
    const size_t n = static_cast<size_t>(std::ceil(s_ / ds)) + 1;
    road.curvature_.assign(n, 0.0);
    road.speed_limit_mps_.assign(n, 0.0);
    road.bank_rad_.assign(n, 0.0);
    road.crossfall_rad_.assign(n, 0.0);
    road.type_.assign(n, 0);
    std::vector<uint8_t> banked(n, 0);
    size_t seg = 0;
    for (size_t i = 0; i < n; ++i) {
      const double s = static_cast<double>(i) * ds;
      while (seg + 1 < segs_.size() && s > segs_[seg].s1) ++seg;
      const Seg& g = segs_[seg];
      const double f = g.s1 > g.s0 ? std::clamp((s - g.s0) / (g.s1 - g.s0), 0.0, 1.0) : 1.0;
      road.curvature_[i] = g.k0 + f * (g.k1 - g.k0);
      road.speed_limit_mps_[i] = g.limit;
      road.type_[i] = static_cast<uint8_t>(g.type);
      banked[i] = g.banked;
    }
    // Crossfall: AR(1) in s, zero mean, clipped to +-max (random sign: left or right edge lower).
    const double rho = std::exp(-ds / cfg.crossfall_correlation_m);
    const double sigma = cfg.crossfall_pct_max / 2.0 / 100.0;
    double q = sigma * rng_.Normal();
    const double qmax = cfg.crossfall_pct_max / 100.0;
    for (size_t i = 0; i < n; ++i) {
      q = rho * q + sigma * std::sqrt(1.0 - rho * rho) * rng_.Normal();
      const double qc = std::clamp(q, -qmax, qmax);
      road.crossfall_rad_[i] = std::atan(qc);
      // Superelevation into curves: outer edge higher, i.e. ISO roll of the road opposite to
      // the turn: theta_se = -sign(kappa) * atan(e * min(1, |kappa| * 300 m)).
      double se = 0.0;
      if (banked[i] && superelevation_pct != 0.0) {
        const double k = road.curvature_[i];
        se = -(k > 0 ? 1.0 : k < 0 ? -1.0 : 0.0) *
             std::atan(superelevation_pct / 100.0 * std::min(1.0, std::fabs(k) * kFullBankRadius_m));
      }
      road.bank_rad_[i] = road.crossfall_rad_[i] + se;
    }
    road.stops_ = stops_;
    PlaceLaneChanges(road, cfg);
    return road;
  }

  static constexpr double kFullBankRadius_m = 300.0;

 private:
  struct Seg {
    double s0, s1, k0, k1;
    RoadType type;
    double limit;
    bool banked;
  };
  void Segment(double length_m, double k0, double k1, RoadType type, double limit, bool banked) {
    if (length_m <= 0.0) return;
    segs_.push_back({s_, s_ + length_m, k0, k1, type, limit, banked});
    s_ += length_m;
  }

  bool FreeOfStops(double s0, double s1) const {
    for (const auto& st : stops_)
      if (st.s_m > s0 - 50.0 && st.s_m < s1 + 50.0) return false;
    return true;
  }

  // Overtaking on motorways (and rarely rural roads), and rare evasive double lane changes.
  void PlaceLaneChanges(Road& road, const config::SimRoad& cfg) {
    double s = 300.0;
    const double end = s_ - 400.0;
    const double step = 250.0;
    while (s < end) {
      const RoadType type = road.Type(s);
      const double limit = road.SpeedLimit(s);
      const double p_overtake = (type == RoadType::kMotorway ? 0.6 : type == RoadType::kRural ? 0.05 : 0.0) * step / 1000.0;
      const double p_evasive = cfg.evasive_per_hour / 60.0 * step / 1000.0;  // per km at ~60 km/h
      const double u = rng_.Uniform();
      const double lane_width = 3.5;
      if (u < p_overtake) {
        const double len = limit * rng_.Uniform(4.0, 7.0);
        const double hold = rng_.Uniform(150.0, 1500.0);
        const double back = limit * rng_.Uniform(4.0, 7.0);
        const double total = len + hold + back;
        if (s + total < end && FreeOfStops(s, s + total)) {
          road.ramps_.push_back({s, len, lane_width});
          road.ramps_.push_back({s + len + hold, back, -lane_width});
          s += total + 100.0;
          continue;
        }
      } else if (u < p_overtake + p_evasive && type != RoadType::kMotorway && limit > 12.0 && limit < 28.0) {
        // Double lane change sized for a peak |a_y| of 3.5..6 m/s^2 at the limit speed:
        // e'' peak = A/2 (pi/L)^2 = a/v^2  =>  L = pi v sqrt(A / (2a)).
        const double a_peak = rng_.Uniform(3.5, 6.0);
        const double height = rng_.Uniform(2.5, 3.5) * rng_.Sign();
        const double len = M_PI * limit * std::sqrt(std::fabs(height) / (2.0 * a_peak));
        const double hold = rng_.Uniform(5.0, 20.0);
        const double total = 2.0 * len + hold;
        if (s + total < end && FreeOfStops(s, s + total)) {
          road.ramps_.push_back({s, len, height});
          road.ramps_.push_back({s + len + hold, len, -height});
          ++road.evasive_count_;
          s += total + 100.0;
          continue;
        }
      }
      s += step;
    }
  }

  Rng& rng_;
  double s_ = 0.0;
  std::vector<Seg> segs_;
  std::vector<StopPoint> stops_;
};

namespace {

constexpr double kKph = 1.0 / 3.6;
constexpr double kDeg = M_PI / 180.0;

double UrbanLimit(Rng& rng) { return (rng.Bernoulli(0.2) ? 30.0 : 50.0) * kKph; }
double RuralLimit(Rng& rng) { return (rng.Bernoulli(0.6) ? 100.0 : 70.0) * kKph; }
double MotorwayLimit(Rng& rng) {
  const double u = rng.Uniform();
  return (u < 0.3 ? 120.0 : u < 0.6 ? 130.0 : 140.0) * kKph;  // 140: no limit, the driver's own pace
}

void JunctionTurn(RoadBuilder& b, Rng& rng, RoadType type, double limit, double radius_lo, double radius_hi) {
  if (rng.Bernoulli(0.5)) b.Stop(rng.Uniform(1.0, 15.0));
  b.Curve(rng.Uniform(radius_lo, radius_hi), rng.Uniform(80.0, 100.0) * kDeg, rng.Uniform(3.0, 6.0), rng.Sign(),
          type, limit, false);
  b.Straight(rng.Uniform(20.0, 60.0), type, limit);
}

// Roundabout (right-hand traffic, counter-clockwise): right entry, left arc, right exit.
void Roundabout(RoadBuilder& b, Rng& rng, RoadType type, double limit) {
  if (rng.Bernoulli(0.3)) b.Stop(rng.Uniform(1.0, 8.0));  // yield
  const double r = rng.Uniform(12.0, 25.0);
  b.Curve(r * 1.2, rng.Uniform(25.0, 40.0) * kDeg, 5.0, -1.0, type, limit, false);
  b.Curve(r, rng.Uniform(60.0, 280.0) * kDeg, 6.0, +1.0, type, limit, false);
  b.Curve(r * 1.5, rng.Uniform(25.0, 40.0) * kDeg, 6.0, -1.0, type, limit, false);
  b.Straight(rng.Uniform(20.0, 60.0), type, limit);
}

// Manoeuvring at walking pace (a car park, a yard): tight turns R 4.5-7 m of 90-270 deg at
// 1.5-3 m/s, steering-wheel angles of 300-700 deg; the estimator's gate rejects them (v_min).
void ParkingTurns(RoadBuilder& b, Rng& rng, int count) {
  for (int k = 0; k < count; ++k) {
    const double limit = rng.Uniform(1.5, 3.0);
    b.Straight(rng.Uniform(3.0, 10.0), RoadType::kUrban, limit);
    b.Curve(rng.Uniform(4.5, 7.0), rng.Uniform(90.0, 270.0) * kDeg, rng.Uniform(1.0, 3.0), rng.Sign(), RoadType::kUrban,
            limit, false);
  }
}

void UrbanStretch(RoadBuilder& b, Rng& rng, double length_m) {
  const double end = b.s() + length_m;
  double limit = UrbanLimit(rng);
  while (b.s() < end) {
    if (rng.Bernoulli(0.15)) limit = UrbanLimit(rng);
    const double u = rng.Uniform();
    if (u < 0.4) {
      b.Straight(rng.Uniform(40.0, 250.0), RoadType::kUrban, limit);
      if (rng.Bernoulli(0.25)) b.Stop(rng.Uniform(5.0, 60.0));  // traffic light
    } else if (u < 0.75) {
      b.Curve(rng.Uniform(30.0, 200.0), rng.Uniform(15.0, 90.0) * kDeg, rng.Uniform(10.0, 30.0), rng.Sign(),
              RoadType::kUrban, limit, false);
    } else if (u < 0.92) {
      JunctionTurn(b, rng, RoadType::kUrban, limit, 7.0, 13.0);
    } else {
      Roundabout(b, rng, RoadType::kUrban, limit);
    }
  }
}

void RuralStretch(RoadBuilder& b, Rng& rng, double length_m) {
  const double end = b.s() + length_m;
  double limit = RuralLimit(rng);
  while (b.s() < end) {
    if (rng.Bernoulli(0.1)) limit = RuralLimit(rng);
    const double u = rng.Uniform();
    if (u < 0.4) {
      b.Straight(rng.Uniform(100.0, 900.0), RoadType::kRural, limit);
    } else if (u < 0.95) {
      const double r = rng.LogUniform(80.0, 800.0);
      b.Curve(r, rng.Uniform(8.0, 80.0) * kDeg, r * rng.Uniform(0.12, 0.35), rng.Sign(), RoadType::kRural, limit, true);
    } else if (u < 0.98) {
      JunctionTurn(b, rng, RoadType::kRural, limit, 10.0, 20.0);
    } else {
      Roundabout(b, rng, RoadType::kRural, limit);
    }
  }
}

void MotorwayStretch(RoadBuilder& b, Rng& rng, double length_m) {
  // Entry ramp (a tight banked loop or a sweeping slip road), then the motorway, then the exit.
  b.Curve(rng.Uniform(50.0, 120.0), rng.Uniform(90.0, 250.0) * kDeg, rng.Uniform(30.0, 60.0), rng.Sign(),
          RoadType::kMotorway, 60.0 * kKph, true);
  b.Straight(rng.Uniform(300.0, 600.0), RoadType::kMotorway, 100.0 * kKph);
  const double end = b.s() + length_m;
  double limit = MotorwayLimit(rng);
  while (b.s() < end) {
    if (rng.Bernoulli(0.1)) limit = MotorwayLimit(rng);
    if (rng.Uniform() < 0.55) {
      b.Straight(rng.Uniform(500.0, 3000.0), RoadType::kMotorway, limit);
    } else {
      const double r = rng.LogUniform(700.0, 3500.0);
      b.Curve(r, rng.Uniform(5.0, 35.0) * kDeg, r * rng.Uniform(0.1, 0.3), rng.Sign(), RoadType::kMotorway, limit,
              true);
    }
  }
  b.Straight(rng.Uniform(200.0, 400.0), RoadType::kMotorway, 100.0 * kKph);
  b.Curve(rng.Uniform(60.0, 150.0), rng.Uniform(60.0, 120.0) * kDeg, rng.Uniform(30.0, 60.0), rng.Sign(),
          RoadType::kMotorway, 70.0 * kKph, true);
}

}  // namespace

Road GenerateRoad(double length_m, const config::SimRoad& cfg, double superelevation_pct, Rng& rng) {
  RoadBuilder b(rng);
  ParkingTurns(b, rng, cfg.parking_turns);
  b.Straight(rng.Uniform(30.0, 80.0), RoadType::kUrban, 30.0 * kKph);  // leaving the parking spot
  const double km = length_m / 1000.0;
  if (km < 5.0) {
    UrbanStretch(b, rng, length_m - b.s());
  } else if (km < 15.0) {
    const double urban1 = rng.Uniform(1.0, 2.5) * 1000.0, urban2 = rng.Uniform(0.5, 2.0) * 1000.0;
    UrbanStretch(b, rng, urban1);
    RuralStretch(b, rng, std::max(500.0, length_m - urban1 - urban2));
    UrbanStretch(b, rng, urban2);
  } else {
    const double urban1 = rng.Uniform(1.0, 4.0) * 1000.0, rural1 = rng.Uniform(2.0, 8.0) * 1000.0;
    const double rural2 = rng.Uniform(1.0, 5.0) * 1000.0, urban2 = rng.Uniform(1.0, 3.0) * 1000.0;
    const double motorway = std::max(2000.0, length_m - urban1 - rural1 - rural2 - urban2);
    UrbanStretch(b, rng, urban1);
    RuralStretch(b, rng, rural1);
    MotorwayStretch(b, rng, motorway);
    RuralStretch(b, rng, rural2);
    UrbanStretch(b, rng, urban2);
  }
  b.Straight(60.0, RoadType::kUrban, 30.0 * kKph);  // into the destination's parking spot
  ParkingTurns(b, rng, cfg.parking_turns);
  b.Stop(2.0);                                      // the end of the drive
  b.Straight(20.0, RoadType::kUrban, 30.0 * kKph);
  return b.Finish(cfg, superelevation_pct);
}

}  // namespace ndsid::sim
