// The drive loop: driver -> vehicle truth (RK4 at step_hz) -> sensors (100 Hz samples).
#include "ndsid/sim/simulator.h"

#include <algorithm>
#include <cmath>

#include "ndsid/common/error.h"
#include "sensors.h"
#include "ndsid/sim/vehicle_truth.h"

namespace ndsid::sim {

void DriveSeries::Reserve(size_t n) {
  for (auto* v : {&t_s, &steer_sw_rad, &speed_mps, &a_y_mps2, &yaw_rate_radps, &yaw_accel_radps2, &side_slip_rad,
                  &a_x_mps2, &roll_rad, &bank_rad, &curvature_1pm, &s_m, &lateral_offset_m, &lane_target_m, &heading_error_rad,
                  &steer_sw_meas_rad, &steer_rate_meas_radps, &speed_meas_mps, &a_y_meas_mps2, &yaw_rate_meas_radps,
                  &a_x_meas_mps2, &wheel_speed_meas_mps[0], &wheel_speed_meas_mps[1], &wheel_speed_meas_mps[2],
                  &wheel_speed_meas_mps[3]})
    v->reserve(n);
  for (auto* v : {&reverse, &valid, &esp_active, &brake, &gear}) v->reserve(n);
}

model::Params<double> BaseParams(const config::SimVehicle& v) {
  return {v.mass_kg, v.yaw_inertia_kgm2, v.cornering_stiffness_front_npr, v.cornering_stiffness_rear_npr,
          v.cg_to_front_m, v.steering_ratio};
}

namespace {

constexpr double kStandstill_mps = 0.01;

struct DrivePlan {
  double length_m = 0.0;
  int driver = 0;
  double mass_delta_kg = 0.0;
  double gap_s = 0.0;
  double ambient_c = 15.0;
  bool reverse_out = false;
  double reverse_m = 6.0;
  double reverse_steer_rad = 0.0;
  double key_on_s = 3.0;
};

// Path in curvilinear coordinates: s' = v cos(chi)/(1 - kappa e), e' = v sin(chi),
// psi_e' = r - kappa s', chi = psi_e + beta (course relative to the road).
struct PathState {
  double s = 0.0, e = 0.0, psi = 0.0;
};
PathState PathDerivative(const Road& road, const PathState& p, double v, double beta, double r) {
  const double kappa = road.Curvature(p.s);
  const double chi = p.psi + beta;
  const double s_dot = v * std::cos(chi) / (1.0 - kappa * p.e);
  return {s_dot, v * std::sin(chi), r - kappa * s_dot};
}

enum class Phase { kKeyOn, kReverse, kReverseHold, kDrive, kStopped, kEnd };

// What one drive's loop reads and never changes.
struct DriveContext {
  const DriverProfile& driver;
  const DrivePlan& plan;
  const Road& road;
  const VehicleTruth& truth;
  const std::vector<double>& v_plan;  // the driver's planned speed over s, on the road's grid [m/s]
  double dt;                          // integration step [s]
  double l;                           // wheelbase [m]
  double eg_belief;                   // the driver's internal model of the car: EG ...
  double is_belief;                   // ... and the steering ratio, off by a few per cent
};

// The loop's state, carried from one integration step to the next.
struct DriveState {
  TruthState x;                      // the vehicle's state (VehicleTruth)
  PathState path;                    // its place on the road
  double v = 0.0;                    // speed [m/s], negative when reversing
  double a_x = 0.0;                  // longitudinal acceleration [m/s^2]
  double steer = 0.0;                // steering-wheel angle [rad]
  double s_release = -1.0;           // the last stop's place: the speed plan resumes after it [m]
  double stop_timer = 0.0;           // time left standing at a stop or after reversing [s]
  double reverse_done = 0.0;         // distance reversed so far [m]
  size_t next_stop = 0;              // the road's next stop
  Phase phase = Phase::kKeyOn;
  double prev_r_kin = 0.0;           // the kinematic yaw rate one step before [rad/s]
  double km_by_type[3] = {0, 0, 0};  // distance driven per road type [km]
};

// The planned speed at s (linear between the grid's points).
double PlannedSpeed(const std::vector<double>& v_plan, double s) {
  const double x = std::clamp(s / Road::kGridStep_m, 0.0, static_cast<double>(v_plan.size() - 1));
  const size_t i = std::min(static_cast<size_t>(x), v_plan.size() - 2);
  return v_plan[i] + (x - static_cast<double>(i)) * (v_plan[i + 1] - v_plan[i]);
}

// The yaw acceleration at step k: the dynamic model's, blended with the kinematic yaw rate's
// difference quotient at low speed.
double YawAcceleration(const DriveContext& c, DriveState& st, const TruthOutputs& o0, int64_t k) {
  const double r_kin = c.truth.KinematicYawRate(st.steer, st.v);
  const double r_dot = o0.blend * o0.r_dot_dyn + (1.0 - o0.blend) * (k == 0 ? 0.0 : (r_kin - st.prev_r_kin) / c.dt);
  st.prev_r_kin = r_kin;
  return r_dot;
}

// The driver's steering (zero-order hold over the step): curvature feed-forward with preview and
// lane-keeping feedback while driving; the reversing lock; hands still otherwise. sn: noise [rad].
double SteeringCommand(const DriveContext& c, const DriveState& st, double vf, double sn) {
  const DriverProfile& driver = c.driver;
  const Road& road = c.road;
  if (st.phase == Phase::kDrive || st.phase == Phase::kStopped) {
    const double s_ff = st.path.s + vf * driver.preview_s;
    const double kappa_ff = road.Curvature(s_ff) + road.LaneOffsetCurvature(s_ff);
    const double la = std::max(driver.lookahead_min_m, vf * driver.lookahead_s);
    const double e_err = st.path.e - road.LaneOffset(st.path.s);
    const double psi_err = st.path.psi - std::atan(road.LaneOffsetSlope(st.path.s));
    const double kappa_fb = -2.0 * (e_err + la * psi_err) / (la * la);
    return c.is_belief * (c.l + c.eg_belief * vf * vf) * (kappa_ff + kappa_fb) + sn;
  }
  if (st.phase == Phase::kReverse) return c.plan.reverse_steer_rad;
  // hands still (key-on), or unwinding after reversing:
  return st.phase == Phase::kReverseHold ? 0.0 : st.steer;
}

// The drive's phases (key-on, reversing out, holding, driving the speed plan, standing at a stop)
// and the acceleration command of each; moves st.phase, and snaps v to 0 where the car stops.
// t: time [s]; vn: the driver's speed noise (relative).
double AccelerationCommand(const DriveContext& c, DriveState& st, double t, double vn) {
  const DriverProfile& driver = c.driver;
  const Road& road = c.road;
  const double dt = c.dt;
  double a_cmd = 0.0;
  if (st.phase == Phase::kKeyOn) {
    a_cmd = 0.0;
    if (t >= c.plan.key_on_s) st.phase = c.plan.reverse_out ? Phase::kReverse : Phase::kDrive;
  } else if (st.phase == Phase::kReverse) {
    const double remaining = c.plan.reverse_m - st.reverse_done;
    const double v_target = -std::min(1.2, std::sqrt(2.0 * 0.6 * std::max(remaining, 0.0)));
    a_cmd = std::clamp((v_target - st.v) / 0.4, -1.0, 1.0);
    if (remaining < 0.02 && std::fabs(st.v) < 0.05) {
      st.phase = Phase::kReverseHold;
      st.stop_timer = 2.5;
      st.v = 0.0;
      st.a_x = 0.0;
    }
  } else if (st.phase == Phase::kReverseHold) {
    st.stop_timer -= dt;
    if (st.stop_timer <= 0.0) st.phase = Phase::kDrive;
  } else if (st.phase == Phase::kStopped) {
    a_cmd = 0.0;
    st.stop_timer -= dt;
    if (st.stop_timer <= 0.0) st.phase = st.next_stop >= road.stops().size() ? Phase::kEnd : Phase::kDrive;
  } else {  // kDrive: track the speed plan, stop at the stops
    const double sp = std::max(st.path.s, st.s_release + Road::kGridStep_m);
    const double ds = Road::kGridStep_m;
    const double vp0 = PlannedSpeed(c.v_plan, sp) * (1.0 + vn), vp1 = PlannedSpeed(c.v_plan, sp + ds) * (1.0 + vn);
    const double a_ff = (vp1 * vp1 - vp0 * vp0) / (2.0 * ds);
    a_cmd = std::clamp(a_ff + 0.6 * (vp0 - st.v), -2.5 * driver.decel_mps2, 1.3 * driver.accel_mps2);
    if (st.next_stop < road.stops().size()) {
      const double d = road.stops()[st.next_stop].s_m - st.path.s;
      if (d < 4.0) {
        a_cmd = std::min(a_cmd, -st.v * st.v / (2.0 * std::max(d - 0.3, 0.05)));
        if (st.v < 0.08) {
          st.phase = Phase::kStopped;
          st.stop_timer = road.stops()[st.next_stop].dwell_s;
          st.s_release = road.stops()[st.next_stop].s_m;
          ++st.next_stop;
          st.v = 0.0;
          st.a_x = 0.0;
          a_cmd = 0.0;
        }
      }
    }
  }
  return a_cmd;
}

// The acceleration follows the command with a 0.3 s lag (at once on the final approach to a stop);
// none while standing.
void FollowAcceleration(const DriveContext& c, DriveState& st, double a_cmd) {
  const Road& road = c.road;
  const bool final_approach =
      st.phase == Phase::kDrive && st.next_stop < road.stops().size() && road.stops()[st.next_stop].s_m - st.path.s < 4.0;
  st.a_x = final_approach ? a_cmd : st.a_x + (a_cmd - st.a_x) * (1.0 - std::exp(-c.dt / 0.3));
  if (st.phase == Phase::kStopped || st.phase == Phase::kKeyOn || st.phase == Phase::kReverseHold) st.a_x = 0.0;
}

// The sensors' sample at time t of the state at the step's start (u0, o0).
void RecordSample(const DriveContext& c, const DriveState& st, double t, const TruthInputs& u0, const TruthOutputs& o0,
                  double r_dot, double bank0, SensorModel& sensors, DriveSeries& out) {
  const Road& road = c.road;
  const Phase phase = st.phase;
  SampleTruth s{t, st.steer, u0.speed_mps, o0.a_y, o0.r, r_dot, o0.beta, st.a_x, o0.roll, bank0,
                road.Curvature(st.path.s), st.path.s, st.path.e, road.LaneOffset(st.path.s), st.path.psi,
                phase == Phase::kReverse || phase == Phase::kReverseHold};
  const uint8_t gear = (phase == Phase::kKeyOn || phase == Phase::kEnd ||
                        (phase == Phase::kStopped && st.next_stop >= road.stops().size()))
                           ? 0
                           : s.reverse ? 1 : 3;
  sensors.Record(s, gear, out);
}

// Advances the truth by one step: steering lag, speed, vehicle (RK4), path (Heun).
// u0, o0: the state at the step's start; vf: the speed before the phases moved it, clamped >= 0.
void AdvanceTruth(const DriveContext& c, DriveState& st, double steer_cmd, const TruthInputs& u0, const TruthOutputs& o0,
                  bool on_road, double vf, double bank0) {
  const Road& road = c.road;
  const double dt = c.dt;
  const double steer1 = steer_cmd + (st.steer - steer_cmd) * std::exp(-dt / c.driver.neuromuscular_tau_s);
  double v1 = st.v + st.a_x * dt;
  if (st.phase == Phase::kDrive && v1 < 0.0) v1 = 0.0;
  if (st.phase == Phase::kReverse && v1 > 0.0) v1 = 0.0;
  const double bank1 = on_road ? road.Bank(st.path.s + vf * dt) : bank0;
  const TruthInputs u1{steer1, v1, bank1};
  c.truth.Step(st.x, u0, u1, dt);
  if (on_road) {
    PathState& path = st.path;
    const TruthOutputs o1 = c.truth.Outputs(st.x, u1);
    const PathState k1 = PathDerivative(road, path, st.v, o0.beta, o0.r);
    const PathState pred{path.s + dt * k1.s, path.e + dt * k1.e, path.psi + dt * k1.psi};
    const PathState k2 = PathDerivative(road, pred, v1, o1.beta, o1.r);
    const double ds_step = 0.5 * dt * (k1.s + k2.s);
    st.km_by_type[static_cast<int>(road.Type(path.s))] += ds_step / 1000.0;
    path.s += ds_step;
    path.e += 0.5 * dt * (k1.e + k2.e);
    path.psi += 0.5 * dt * (k1.psi + k2.psi);
    // passed a stop without stopping (should not happen with the stop law): count it as done
    if (st.next_stop < road.stops().size() && path.s > road.stops()[st.next_stop].s_m + 2.0) ++st.next_stop;
  } else if (st.phase == Phase::kReverse) {
    st.reverse_done += 0.5 * dt * (std::fabs(st.v) + std::fabs(v1));
  }
  st.steer = steer1;
  st.v = v1;
}

// One drive: its own random streams (road, driver, sensors, and the gyro's per-drive offset), the
// truth of its load, then the loop: driver -> phases -> sample -> truth, step by step.
DriveResult SimulateDrive(const config::SimulationConfig& cfg, const DriverProfile& driver, const DrivePlan& plan,
                          int index, int64_t start_ns, double odometer_km) {
  const double dt = 1.0 / cfg.integration.step_hz;
  const int sub = static_cast<int>(std::lround(cfg.integration.step_hz / kOutputRate_hz));
  Rng road_rng(MixSeed(cfg.seed, 1000 + 8 * static_cast<uint64_t>(index)));
  Rng driver_rng(MixSeed(cfg.seed, 1001 + 8 * static_cast<uint64_t>(index)));
  Rng sensor_rng(MixSeed(cfg.seed, 1002 + 8 * static_cast<uint64_t>(index)));

  DriveResult result;
  result.index = index;
  result.start_epoch_ns = start_ns;
  result.driver = driver.id;
  result.ambient_temp_c = plan.ambient_c;
  result.odometer_start_km = odometer_km;
  model::Params<double> p = BaseParams(cfg.vehicle);
  const double m0 = p.m;
  p.m += plan.mass_delta_kg;
  p.Jz *= p.m / m0;  // load at the CG, same radius of gyration
  result.params = p;
  const double l = cfg.vehicle.wheelbase_m;
  const VehicleTruth truth(p, l, cfg.effects, cfg.integration);
  result.self_steer_gradient = truth.self_steer_gradient();

  const Road road = GenerateRoad(plan.length_m, cfg.road, cfg.effects.superelevation_pct, road_rng);
  const std::vector<double> v_plan = PlanSpeed(road, driver);
  const DriveContext ctx{driver, plan, road, truth, v_plan, dt, l,
                         truth.self_steer_gradient() * driver.belief_eg_factor, p.is * driver.belief_is_factor};
  OrnsteinUhlenbeck steer_noise(driver.steer_noise_rad, driver.steer_noise_tau_s);
  OrnsteinUhlenbeck speed_noise(driver.speed_noise, 20.0);
  steer_noise.Reset(driver_rng);
  speed_noise.Reset(driver_rng);

  // The gyro's offset on this drive: r0 plus a per-drive part from a stream of its own (the other
  // streams, and so every other draw, are the same with and without it).
  config::SimulationConfig drive_cfg = cfg;
  if (cfg.effects.gyro_offset_drive_degps > 0) {
    Rng gyro_rng(MixSeed(cfg.seed, 1003 + 8 * static_cast<uint64_t>(index)));
    drive_cfg.effects.gyro_offset_degps += gyro_rng.Uniform(-1.0, 1.0) * cfg.effects.gyro_offset_drive_degps;
  }
  result.gyro_offset_degps = drive_cfg.effects.gyro_offset_degps;
  SensorModel sensors(drive_cfg, dt, sensor_rng, MixSeed(cfg.seed, 1004 + 8 * static_cast<uint64_t>(index)));
  DriveState st;
  const double max_time = 3600.0 * 6.0 + plan.length_m / 2.0;
  DriveSeries& out = result.series;
  out.Reserve(static_cast<size_t>(plan.length_m / 15.0 * kOutputRate_hz) + 1000);

  for (int64_t k = 0; st.phase != Phase::kEnd; ++k) {
    const double t = static_cast<double>(k) * dt;
    const bool on_road = st.phase != Phase::kReverse && st.phase != Phase::kReverseHold && st.phase != Phase::kKeyOn;
    const double bank0 = road.Bank(st.path.s);
    const TruthInputs u0{st.steer, st.v, bank0};  // the state at t (the phases below may snap v to 0)
    const TruthOutputs o0 = truth.Outputs(st.x, u0);
    const double r_dot = YawAcceleration(ctx, st, o0, k);
    sensors.PushSteer(st.steer);
    const double vf = std::max(st.v, 0.0);
    const double sn = steer_noise.Step(driver_rng, dt);
    const double vn = speed_noise.Step(driver_rng, dt);
    const double steer_cmd = SteeringCommand(ctx, st, vf, sn);
    FollowAcceleration(ctx, st, AccelerationCommand(ctx, st, t, vn));
    if (k % sub == 0) RecordSample(ctx, st, t, u0, o0, r_dot, bank0, sensors, out);
    if (st.phase == Phase::kEnd || t > max_time) break;
    AdvanceTruth(ctx, st, steer_cmd, u0, o0, on_road, vf, bank0);
  }
  result.stats = ComputeDriveStats(out);
  result.stats.urban_km = st.km_by_type[0];
  result.stats.rural_km = st.km_by_type[1];
  result.stats.motorway_km = st.km_by_type[2];
  result.stats.evasive = road.evasive_count();
  return result;
}

}  // namespace

std::vector<DriverProfile> SimulateDrives(const config::SimulationConfig& cfg,
                                          const std::function<void(DriveResult&&)>& sink) {
  config::ValidateSimulationConfig(cfg);
  Rng driver_rng(MixSeed(cfg.seed, 1));
  const std::vector<DriverProfile> drivers = MakeDrivers(cfg.drivers, driver_rng);
  Rng sched(MixSeed(cfg.seed, 2));
  int64_t t_ns = cfg.start_epoch_s * 1000000000LL;
  double odometer_km = sched.Uniform(20000.0, 80000.0);
  double hours = 0.0;
  const auto& d = cfg.duration;
  for (int i = 0;; ++i) {
    if (d.drives > 0 ? i >= d.drives : hours >= d.hours) break;
    DrivePlan plan;  // every draw is made whatever the effects, so effect on/off runs match
    const bool is_short = sched.Uniform() < d.short_drive_fraction;
    const double short_m = sched.Uniform(400.0, 1900.0);
    const double long_m = sched.LogUniform(d.min_km, d.max_km) * 1000.0;
    plan.length_m = is_short ? short_m : long_m;
    plan.driver = sched.Index(static_cast<int>(drivers.size()));
    const double mass_u = sched.Uniform(-1.0, 1.0);
    plan.mass_delta_kg = cfg.effects.mass_schedule_kg.empty()
                             ? cfg.effects.mass_change_kg * mass_u
                             : cfg.effects.mass_schedule_kg[static_cast<size_t>(i) % cfg.effects.mass_schedule_kg.size()];
    plan.gap_s = sched.LogUniform(d.gap_min_h, d.gap_max_h) * 3600.0;
    plan.ambient_c = sched.Uniform(-5.0, 30.0);
    plan.reverse_out = sched.Bernoulli(0.4);
    plan.reverse_m = sched.Uniform(4.0, 10.0);
    plan.reverse_steer_rad = sched.Sign() * sched.Uniform(150.0, 450.0) * M_PI / 180.0;
    plan.key_on_s = sched.Uniform(2.0, 6.0);
    DriveResult drive = SimulateDrive(cfg, drivers[static_cast<size_t>(plan.driver)], plan, i, t_ns, odometer_km);
    const double duration_s = drive.series.size() / kOutputRate_hz;
    hours += duration_s / 3600.0;
    odometer_km += drive.stats.distance_km * (1.0 + cfg.effects.speed_scale_pct / 100.0);
    t_ns += static_cast<int64_t>(std::llround((duration_s + plan.gap_s) * 1e6)) * 1000;
    sink(std::move(drive));
  }
  return drivers;
}

SimulationResult Simulate(const config::SimulationConfig& cfg) {
  SimulationResult result;
  result.config = cfg;
  result.drivers = SimulateDrives(cfg, [&](DriveResult&& d) { result.drives.push_back(std::move(d)); });
  return result;
}

DriveStats ComputeDriveStats(const DriveSeries& s) {
  DriveStats st;
  const double dt = 1.0 / kOutputRate_hz;
  std::vector<double> ay;
  ay.reserve(s.size());
  size_t gated = 0;
  bool was_standing = false;
  for (size_t i = 0; i < s.size(); ++i) {
    const double v = std::fabs(s.speed_mps[i]);
    st.distance_km += v * dt / 1000.0;
    const bool standing = v < kStandstill_mps;
    if (standing) st.standstill_s += dt;
    if (standing && !was_standing && i > 0) ++st.stops;
    was_standing = standing;
    if (v > 1.0) {
      st.moving_s += dt;
      ay.push_back(std::fabs(s.a_y_meas_mps2[i]));
    }
    if (s.speed_meas_mps[i] > 5.0 && std::fabs(s.a_y_meas_mps2[i]) < 4.0 && !s.reverse[i] && s.valid[i] &&
        !s.esp_active[i])
      ++gated;
  }
  st.duration_s = static_cast<double>(s.size()) * dt;
  st.mean_speed_kph = st.moving_s > 0 ? st.distance_km / (st.moving_s / 3600.0) : 0.0;
  st.gated_fraction = s.size() ? static_cast<double>(gated) / static_cast<double>(s.size()) : 0.0;
  if (!ay.empty()) {
    const auto n = static_cast<double>(ay.size());
    st.frac_ay_below_1 = static_cast<double>(std::count_if(ay.begin(), ay.end(), [](double a) { return a < 1.0; })) / n;
    st.frac_ay_below_2 = static_cast<double>(std::count_if(ay.begin(), ay.end(), [](double a) { return a < 2.0; })) / n;
    st.frac_ay_below_5 = static_cast<double>(std::count_if(ay.begin(), ay.end(), [](double a) { return a < 5.0; })) / n;
    auto q = [&](double p) {
      const size_t i = std::min(ay.size() - 1, static_cast<size_t>(p * n));
      std::nth_element(ay.begin(), ay.begin() + static_cast<std::ptrdiff_t>(i), ay.end());
      return ay[i];
    };
    st.abs_ay_q50 = q(0.50);
    st.abs_ay_q75 = q(0.75);
    st.abs_ay_q90 = q(0.90);
    st.abs_ay_q99 = q(0.99);
    st.abs_ay_max = *std::max_element(ay.begin(), ay.end());
  }
  return st;
}

}  // namespace ndsid::sim
