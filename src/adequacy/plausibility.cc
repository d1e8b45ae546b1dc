#include "ndsid/adequacy/plausibility.h"
#include "ndsid/common/format.h"

#include <algorithm>
#include <cmath>
#include <cstdarg>
#include <cstdio>
#include <map>

namespace ndsid::adequacy {
namespace {

// Uncentred regression through the origin, y = gain x: both sides are zero-mean physically, so
// an offset (sensor bias, road bank) shows as a small loss of correlation, not as a wrong gain.
struct Regression {
  double sxx = 0, sxy = 0, syy = 0, seconds = 0;
  void Add(double x, double y, double dt) {
    sxx += x * x * dt, sxy += x * y * dt, syy += y * y * dt, seconds += dt;
  }
  void Merge(const Regression& o) { sxx += o.sxx, sxy += o.sxy, syy += o.syy, seconds += o.seconds; }
  double gain() const { return sxx > 0 ? sxy / sxx : 0; }
  double correlation() const { return sxx > 0 && syy > 0 ? sxy / std::sqrt(sxx * syy) : 0; }
  // The gain's standard error, counting one independent sample per kIndependentS of driving
  // (the residuals of driving data are correlated over about a second).
  double gain_se() const {
    if (!(sxx > 0) || seconds <= 0) return INFINITY;
    const double n_eff = std::max(1.0, seconds / kIndependentS);
    const double rss_per_s = std::max(0.0, syy - sxy * sxy / sxx) / seconds;  // residual power
    return std::sqrt(rss_per_s / (sxx / seconds) / n_eff);
  }
  static constexpr double kIndependentS = 1.0;
};

struct DriveSums {
  Regression kinematic;  // a_y on v r
  Regression steer;      // r on v d_sw (or a_y on v^2 d_sw without a yaw rate)
  bool steer_uses_yaw = true;
  int64_t t0_ns = INT64_MAX;
};

// Samples that carry the information: turning enough that v r or a_y (or d_sw) stands out of the
// noise.
constexpr double kMinKinematicMps2 = 0.5;  // |v r| [m/s^2]
constexpr double kMinSteerRad = 0.05;      // |d_sw| at the steering wheel [rad], about 3 deg, ...
// ... for the default steer-ratio range 8..30; another range (a road-wheel angle: 0.7..1.5) scales
// it by the ratio of the ranges' middles (geometric means): the same turn of the road wheels.
constexpr double kDefaultSteerRatioProduct = 8.0 * 30.0;
double MinSteerRad(const config::PlausibilityConfig& q) {
  return kMinSteerRad * std::sqrt(q.steer_ratio_min * q.steer_ratio_max / kDefaultSteerRatioProduct);
}
constexpr double kMaxSteerLatAccel = 3.0;  // |a_y| for the steering check: the linear range
// a_y = v (r + beta'): the kinematic relation a_y = v r holds where beta' is small, in quasi-steady
// turning. Samples whose yaw acceleration (over +- kYawAccelHalfWindowS) exceeds this are left out
// of the kinematics check: in a quick transient (a race car between corners, a low-speed
// manoeuvre) beta' makes a_y lead or lag v r by a tenth of a second, which a gain cannot show.
constexpr double kMaxYawAccelRadps2 = 0.05;
constexpr double kYawAccelHalfWindowS = 0.25;

// Whether sample k of the segment turns quasi-steadily: its yaw acceleration over
// +- kYawAccelHalfWindowS (a difference over half a second: the gyro's noise averages out) is small.
bool QuasiSteady(const stats::Segment& seg, size_t k) {
  const size_t h = std::max<size_t>(1, static_cast<size_t>(std::lround(kYawAccelHalfWindowS / seg.dt_s)));
  const size_t a = k >= h ? k - h : 0, b = std::min(seg.samples.size() - 1, k + h);
  if (b <= a) return false;
  const double ra = seg.samples[a].yaw_rate_radps, rb = seg.samples[b].yaw_rate_radps;
  return std::isfinite(ra) && std::isfinite(rb) && std::abs(rb - ra) / ((b - a) * seg.dt_s) <= kMaxYawAccelRadps2;
}

void Accumulate(const stats::Segment& seg, double min_steer_rad, DriveSums& d) {
  d.t0_ns = std::min(d.t0_ns, seg.t0_ns);
  d.steer_uses_yaw = seg.has_yaw_rate;
  for (size_t k = 0; k < seg.samples.size(); ++k) {
    const stats::SegmentSample& s = seg.samples[k];
    const double v = s.speed_mps, r = s.yaw_rate_radps, a = s.lat_accel_mps2, delta = s.steer_rad;
    if (!std::isfinite(v) || !std::isfinite(a) || !std::isfinite(delta)) continue;
    if (seg.has_yaw_rate && std::isfinite(r)) {
      // Either side large: a unit mistake that shrinks one side must not hide the samples.
      if ((std::abs(v * r) > kMinKinematicMps2 || std::abs(a) > kMinKinematicMps2) && QuasiSteady(seg, k))
        d.kinematic.Add(v * r, a, seg.dt_s);
      if (std::abs(delta) > min_steer_rad && std::abs(a) < kMaxSteerLatAccel) d.steer.Add(v * delta, r, seg.dt_s);
    } else if (std::abs(delta) > min_steer_rad && std::abs(a) < kMaxSteerLatAccel) {
      d.steer.Add(v * v * delta, a, seg.dt_s);
    }
  }
}

// The likely causes of a kinematic gain g (correlation rho) outside the limits, most likely first.
std::string KinematicCauses(double g, double rho, const config::PlausibilityConfig& q) {
  if (g < 0) return "the sign of lateral_acceleration or of yaw_rate is flipped";
  // The factors a unit mix-up gives (km/h vs m/s, mph vs km/h and m/s, g vs m/s^2, deg vs rad).
  constexpr double kUnitFactors[] = {3.6, 1.609344, 2.236936, 9.81, 57.29578};
  const auto near = [&](double x, double f) { return std::abs(std::log(x / f)) < std::log(1.12); };
  std::string unit;
  for (double f : kUnitFactors)
    if (near(g, f) || near(g, 1 / f)) unit = Fmt("%.4g", g > 1 ? f : 1 / f);
  const bool correlated = rho >= q.kinematic_correlation_min;
  if (correlated && !unit.empty())
    return "a unit is wrong (the gain is a unit factor, " + unit + ": vehicle_speed, lateral_acceleration or yaw_rate)";
  if (correlated && g > 0.5 && g < 2)
    return Fmt("a sensor scale error: the accelerometer, the gyro or the speed reads %+.0f %% against the others "
               "(a mounting tilt, a miscalibrated sensor, a tyre radius; or a unit is wrong)", 100 * (g - 1));
  if (correlated) return "a unit is wrong (vehicle_speed, lateral_acceleration or yaw_rate)";
  if (g > 0.5 && g < 2)
    return "a_y and v*r move together only loosely: noise on a_y or the yaw rate (a vibrating sensor: "
           "signals.<role>.lowpass_hz), or a wrong signal mapped";
  return "a_y and v*r do not move together: a wrong signal mapped, or one too noisy to use";
}

void DataChecks(const DriveSums& d, const config::PlausibilityConfig& q, std::vector<Check>& out) {
  Check k{.name = "kinematics"};
  k.informative_s = d.kinematic.seconds;
  if (k.informative_s >= q.min_informative_s) {
    const double g = d.kinematic.gain(), rho = d.kinematic.correlation(), se = d.kinematic.gain_se();
    k.value = g;
    k.value_se = se;
    const bool ok = g >= q.kinematic_gain_min && g <= q.kinematic_gain_max && rho >= q.kinematic_correlation_min;
    k.verdict = ok ? Verdict::kPassed : Verdict::kFailed;
    k.message = Fmt("a_y against v*r in quasi-steady turning: gain %.3f +- %.3f (physically 1, accepted %.2f..%.2f), correlation %.3f",
                    g, se, q.kinematic_gain_min, q.kinematic_gain_max, rho);
    if (!ok) k.message += ": " + KinematicCauses(g, rho, q);
  } else {
    k.message = Fmt("a_y against v*r: skipped, %.0f s of quasi-steady turning (needs %.0f s)", k.informative_s, q.min_informative_s);
  }
  out.push_back(k);

  Check s{.name = "steering_sign"};
  s.informative_s = d.steer.seconds;
  if (s.informative_s >= q.min_informative_s) {
    const double rho = d.steer.correlation();
    s.value = rho;
    s.verdict = rho >= q.steer_yaw_correlation_min ? Verdict::kPassed : Verdict::kFailed;
    s.message = Fmt(d.steer_uses_yaw ? "yaw rate against v*steering: correlation %.3f (positive in ISO 8855, needs >= %.2f)"
                                     : "a_y against v^2*steering: correlation %.3f (positive in ISO 8855, needs >= %.2f)",
                    rho, q.steer_yaw_correlation_min);
    if (s.verdict == Verdict::kFailed)
      s.message += rho < 0 ? ": the sign of steering_wheel_angle is flipped" : ": steering and turning do not move together";
  } else {
    s.message = Fmt("steering sign: skipped, %.0f s of steering data (needs %.0f s)", s.informative_s, q.min_informative_s);
  }
  out.push_back(s);
}

}  // namespace

const char* VerdictName(Verdict v) {
  switch (v) {
    case Verdict::kPassed: return "passed";
    case Verdict::kFailed: return "failed";
    case Verdict::kSkipped: return "skipped";
  }
  return "?";
}

bool PlausibilityReport::passed() const {
  for (const Check& c : checks)
    if (c.verdict == Verdict::kFailed) return false;
  return true;
}

bool PlausibilityReport::undetermined() const {
  bool any = false;
  for (const Check& c : checks) {
    if (c.verdict != Verdict::kFailed) continue;
    if (c.name != "determined") return false;
    any = true;
  }
  return any;
}

namespace {
// What a failed check says about the estimate, before its message.
std::string ReasonPrefix(const std::string& check) {
  if (check == "determined") return "not determined: ";
  if (check == "converged") return "not converged: ";
  if (check.rfind("explained_", 0) == 0) return "not explained: ";
  if (check == "bounds") return "set by the box: ";
  if (check == "steady_state") return "contradicts the steady state: ";
  if (check == "halves") return "not reproducible: ";
  return "implausible: ";
}
}  // namespace

std::string PlausibilityReport::Reason() const {
  std::string out;
  for (const Check& c : checks) {
    if (c.verdict != Verdict::kFailed) continue;
    out += std::string(out.empty() ? "" : "; ") + ReasonPrefix(c.name) + c.message;
  }
  return out;
}

PlausibilityReport CheckData(const std::vector<const stats::Segment*>& segments, const config::PlausibilityConfig& limits) {
  std::map<int64_t, DriveSums> drives;
  for (const stats::Segment* seg : segments) Accumulate(*seg, MinSteerRad(limits), drives[seg->drive_id]);
  PlausibilityReport report;
  DriveSums all;
  for (const auto& [id, d] : drives) {
    all.kinematic.Merge(d.kinematic);
    all.steer.Merge(d.steer);
    all.steer_uses_yaw = d.steer_uses_yaw;
    DriveChecks dc{.drive_id = id, .t0_ns = d.t0_ns};
    DataChecks(d, limits, dc.checks);
    for (const Check& c : dc.checks) {
      if (c.verdict == Verdict::kFailed) {
        ++report.drives_failed;
        break;
      }
    }
    report.drives.push_back(std::move(dc));
  }
  DataChecks(all, limits, report.checks);
  return report;
}

namespace {

Check WheelSpeedCheck(const SpeedSums& s, const config::PlausibilityConfig& q) {
  Check c{.name = "wheel_speed"};
  c.informative_s = s.seconds;
  if (s.seconds < q.min_informative_s || !(s.sww > 0) || !(s.svv > 0)) {
    c.message = Fmt("vehicle_speed against the wheel speeds: skipped, %.0f s moving (needs %.0f s)", s.seconds, q.min_informative_s);
    return c;
  }
  const double ratio = s.svw / s.sww, rho = s.svw / std::sqrt(s.sww * s.svv);
  c.value = ratio;
  const bool ok = ratio >= q.wheel_speed_ratio_min && ratio <= q.wheel_speed_ratio_max && rho >= q.wheel_speed_correlation_min;
  c.verdict = ok ? Verdict::kPassed : Verdict::kFailed;
  c.message = Fmt("vehicle_speed against the wheel speeds' mean: ratio %.3f (accepted %.2f..%.2f), correlation %.3f", ratio,
                  q.wheel_speed_ratio_min, q.wheel_speed_ratio_max, rho);
  if (!ok) {
    c.message += rho >= q.wheel_speed_correlation_min ? ": a unit is wrong (vehicle_speed or wheel_speed: km/h, m/s, mph)"
                                                       : ": speed and wheel speeds do not move together (wrong signal mapped?)";
  }
  return c;
}

}  // namespace

void CheckWheelSpeed(const std::map<int64_t, SpeedSums>& by_drive, const config::PlausibilityConfig& q,
                     PlausibilityReport& report) {
  if (by_drive.empty()) return;
  SpeedSums all;
  for (const auto& [drive_id, s] : by_drive) {
    const int64_t id = drive_id;  // a copy: clang cannot capture a structured binding
    all.sww += s.sww, all.svw += s.svw, all.svv += s.svv, all.seconds += s.seconds;
    all.t0_ns = std::min(all.t0_ns, s.t0_ns);
    const Check c = WheelSpeedCheck(s, q);
    auto it = std::find_if(report.drives.begin(), report.drives.end(), [&](const DriveChecks& d) { return d.drive_id == id; });
    if (it == report.drives.end()) {
      report.drives.push_back(DriveChecks{.drive_id = id, .t0_ns = s.t0_ns});
      it = report.drives.end() - 1;
    }
    const bool failed_before = std::any_of(it->checks.begin(), it->checks.end(), [](const Check& x) { return x.verdict == Verdict::kFailed; });
    if (c.verdict == Verdict::kFailed && !failed_before) ++report.drives_failed;
    it->checks.push_back(c);
  }
  report.checks.push_back(WheelSpeedCheck(all, q));
}

void CheckEstimate(const EstimateFacts& f, const config::PlausibilityConfig& q, PlausibilityReport& report) {
  Check ratio{.name = "steer_ratio"};
  if (f.steer_ratio > 0) {
    ratio.value = f.steer_ratio;
    ratio.verdict = f.steer_ratio >= q.steer_ratio_min && f.steer_ratio <= q.steer_ratio_max ? Verdict::kPassed : Verdict::kFailed;
    ratio.message = Fmt("steady-state steer ratio %.3g (accepted %.2g..%.2g)", f.steer_ratio, q.steer_ratio_min, q.steer_ratio_max);
    // Near 1 the bus carries the road wheels' angle; near 15 the steering wheel's.
    if (ratio.verdict == Verdict::kFailed)
      ratio.message += f.steer_ratio > q.steer_ratio_max
                           ? (f.steer_ratio > 5 && q.steer_ratio_max < 5
                                  ? ": is steering_wheel_angle the steering wheel's angle (vehicle.steering_angle_at: steering_wheel)?"
                                  : ": is steering_wheel_angle in rad but configured in deg, or vice versa?")
                           : (f.steer_ratio < 2.5 ? ": is steering_wheel_angle the road wheels' angle (vehicle.steering_angle_at: "
                                                    "road_wheels), or its unit wrong?"
                                                  : ": neither a unit mistake (x57) nor a road-wheel angle (about 1): too little "
                                                    "steady turning to fix the ratio, or a wrong vehicle.wheelbase_m?");
  } else {
    ratio.message = "steady-state steer ratio: skipped (no steady-state estimate yet)";
  }
  report.checks.push_back(ratio);

  Check range{.name = "eg_range"};
  range.value = f.eg_deg_per_g;
  range.verdict = f.eg_deg_per_g >= q.eg_min_deg_per_g && f.eg_deg_per_g <= q.eg_max_deg_per_g ? Verdict::kPassed : Verdict::kFailed;
  range.message = Fmt("EG %.2f deg/g (road vehicles %.0f..%.0f deg/g)", f.eg_deg_per_g, q.eg_min_deg_per_g, q.eg_max_deg_per_g);
  report.checks.push_back(range);

  Check det{.name = "determined"};
  const double abs_eg = std::abs(f.eg_deg_per_g);
  det.value = abs_eg > 0 ? f.eg_se_deg_per_g / abs_eg : INFINITY;
  const bool sigma_ok = f.eg_se_deg_per_g <= q.eg_se_floor_deg_per_g || f.eg_se_deg_per_g <= q.eg_rel_se_max * abs_eg;
  const bool bounds_ok = f.free_params == 0 || f.free_params_at_bound < f.free_params;
  det.verdict = sigma_ok && bounds_ok ? Verdict::kPassed : Verdict::kFailed;
  det.message = Fmt("EG %.2f +- %.2f deg/g (sigma/|EG| %.2f", f.eg_deg_per_g, f.eg_se_deg_per_g, det.value) +
                Fmt(", accepted <= %.2f or sigma <= %.2f deg/g)", q.eg_rel_se_max, q.eg_se_floor_deg_per_g) +
                Fmt(", %d of %d free parameters on their bounds", f.free_params_at_bound, f.free_params);
  if (!sigma_ok) det.message += ": the data do not determine EG (too little or too uniform driving)";
  if (!bounds_ok) det.message += ": every free parameter is on its bound (box too narrow, or a sign/unit error)";
  report.checks.push_back(det);
}

}  // namespace ndsid::adequacy
