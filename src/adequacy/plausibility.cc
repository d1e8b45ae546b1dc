#include "ndsid/adequacy/plausibility.h"

#include <algorithm>
#include <cmath>
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
};

struct DriveSums {
  Regression kinematic;  // a_y on v r
  Regression steer;      // r on v d_sw (or a_y on v^2 d_sw without a yaw rate)
  bool steer_uses_yaw = true;
  int64_t t0_ns = INT64_MAX;
};

std::string Fmt(const char* format, double a, double b = 0, double c = 0, double d = 0) {
  char buf[256];
  std::snprintf(buf, sizeof buf, format, a, b, c, d);
  return buf;
}

// Samples that carry the information: turning enough that v r or a_y (or d_sw) stands out of the
// noise.
constexpr double kMinKinematicMps2 = 0.5;  // |v r| [m/s^2]
constexpr double kMinSteerRad = 0.05;      // |d_sw| at the steering wheel [rad], about 3 deg
constexpr double kMaxSteerLatAccel = 3.0;  // |a_y| for the steering check: the linear range

void Accumulate(const stats::Segment& seg, DriveSums& d) {
  d.t0_ns = std::min(d.t0_ns, seg.t0_ns);
  d.steer_uses_yaw = seg.has_yaw_rate;
  for (const stats::SegmentSample& s : seg.samples) {
    const double v = s.speed_mps, r = s.yaw_rate_radps, a = s.lat_accel_mps2, delta = s.steer_rad;
    if (!std::isfinite(v) || !std::isfinite(a) || !std::isfinite(delta)) continue;
    if (seg.has_yaw_rate && std::isfinite(r)) {
      // Either side large: a unit mistake that shrinks one side must not hide the samples.
      if (std::abs(v * r) > kMinKinematicMps2 || std::abs(a) > kMinKinematicMps2) d.kinematic.Add(v * r, a, seg.dt_s);
      if (std::abs(delta) > kMinSteerRad && std::abs(a) < kMaxSteerLatAccel) d.steer.Add(v * delta, r, seg.dt_s);
    } else if (std::abs(delta) > kMinSteerRad && std::abs(a) < kMaxSteerLatAccel) {
      d.steer.Add(v * v * delta, a, seg.dt_s);
    }
  }
}

void DataChecks(const DriveSums& d, const config::PlausibilityConfig& q, std::vector<Check>& out) {
  Check k{.name = "kinematics"};
  k.informative_s = d.kinematic.seconds;
  if (k.informative_s >= q.min_informative_s) {
    const double g = d.kinematic.gain(), rho = d.kinematic.correlation();
    k.value = g;
    const bool ok = g >= q.kinematic_gain_min && g <= q.kinematic_gain_max && rho >= q.kinematic_correlation_min;
    k.verdict = ok ? Verdict::kPassed : Verdict::kFailed;
    k.message = Fmt("a_y against v*r: gain %.3f (physically 1, accepted %.2f..%.2f), correlation %.3f", g,
                    q.kinematic_gain_min, q.kinematic_gain_max, rho);
    if (!ok) {
      if (g < 0)
        k.message += ": the sign of lateral_acceleration or of yaw_rate is flipped";
      else if (rho >= q.kinematic_correlation_min)
        k.message += ": a unit is wrong (vehicle_speed, lateral_acceleration or yaw_rate)";
      else
        k.message += ": a_y and v*r do not move together (wrong signal mapped?)";
    }
  } else {
    k.message = Fmt("a_y against v*r: skipped, %.0f s of turning data (needs %.0f s)", k.informative_s, q.min_informative_s);
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

std::string PlausibilityReport::Reason() const {
  std::string out;
  for (const Check& c : checks) {
    if (c.verdict != Verdict::kFailed) continue;
    out += std::string(out.empty() ? "" : "; ") + (c.name == "determined" ? "not determined: " : "implausible: ") + c.message;
  }
  return out;
}

PlausibilityReport CheckData(const std::vector<const stats::Segment*>& segments, const config::PlausibilityConfig& limits) {
  std::map<int64_t, DriveSums> drives;
  for (const stats::Segment* seg : segments) Accumulate(*seg, drives[seg->drive_id]);
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
    ratio.message = Fmt("steady-state steer ratio %.1f (road vehicles %.0f..%.0f)", f.steer_ratio, q.steer_ratio_min, q.steer_ratio_max);
    if (ratio.verdict == Verdict::kFailed)
      ratio.message += f.steer_ratio > q.steer_ratio_max ? ": is steering_wheel_angle in rad but configured in deg, or vice versa?"
                                                         : ": is steering_wheel_angle the road-wheel angle, or its unit wrong?";
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
                Fmt(", %.0f of %.0f free parameters on their bounds", f.free_params_at_bound, f.free_params);
  if (!sigma_ok) det.message += ": the data do not determine EG (too little or too uniform driving)";
  if (!bounds_ok) det.message += ": every free parameter is on its bound (box too narrow, or a sign/unit error)";
  report.checks.push_back(det);
}

}  // namespace ndsid::adequacy
