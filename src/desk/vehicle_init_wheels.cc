// `ndsid init`'s wheel speeds (vehicle_init_detail.h): chosen by physics, not by their names.
// Every signal with a corner and a speed-like unit or name is a candidate; per corner the one
// that follows the vehicle speed best is kept when it correlates above 0.95 while moving. Where
// the names give no corners, the wheels are told from other speeds by their left-right
// difference: a wheel runs r b/2 faster or slower than the centre of the axle, so its deviation
// from the vehicle speed follows the yaw rate, with one sign on the left and the other on the
// right (a copy of the vehicle speed, a displayed speed or a transmission speed does not). The
// mean of the kept ones regressed on the vehicle speed gives their scale: a unit (km/h, m/s,
// mph) or, for rotational speeds (1/min), the rolling radius.
#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <cmath>

#include "vehicle_init_detail.h"

namespace ndsid::desk::init_detail {

using config::Role;

namespace {

constexpr double kWheelCorrelationMin = 0.95;  // a wheel speed follows the vehicle speed this closely
constexpr double kMovingWheels_mps = 3.0;      // the scale fit's samples
const char* const kCornerNames[] = {"FL", "FR", "RL", "RR"};

enum class WheelUnit { kSpeed, kRpm, kUnknown };

WheelUnit KindOf(const Source& s) {
  if (IsRpmUnit(s.unit)) return WheelUnit::kRpm;
  return MatchUnit(SpeedUnits(), s.unit) >= 0 ? WheelUnit::kSpeed : WheelUnit::kUnknown;
}

// The mean of the chosen wheels on the grid (bus units).
std::vector<double> MeanOf(Grid& grid, const std::vector<Source>& wheels) {
  std::vector<double> mean(grid.size(), 0.0);
  for (const auto& w : wheels) {
    const auto& g = grid.Of(w);
    for (size_t i = 0; i < mean.size(); ++i) mean[i] += g[i] / static_cast<double>(wheels.size());
  }
  return mean;
}

std::string SumOf(const std::vector<Source>& wheels) {
  std::string sum;
  for (const auto& w : wheels) sum += (sum.empty() ? "" : " + ") + w.expression;
  return "(" + sum + ")";
}

// The wheels without a corner in their names: candidates that follow the vehicle speed, scaled
// onto it, whose deviation from it follows the yaw rate r (bus units) with a correlation above
// 0.5; kept when both signs of that slope (left and right) are among them, with slopes within a
// factor 2 of each other (the same half-track on both sides).
struct SideWheel {
  const Source* source;
  double corr_v;     // with the vehicle speed
  double slope;      // of (scaled wheel - speed) on r: +-b/2 by side (bus units; which is left: r's sign)
  double corr_r;     // of that deviation with r
};
constexpr double kSideCorrelationMin = 0.5;

std::vector<SideWheel> WheelsBySide(Grid& grid, const std::vector<Source>& candidates, const Source& speed,
                                    const std::vector<double>& vg, const std::vector<double>& r) {
  std::vector<SideWheel> found;
  for (const auto& c : candidates) {
    if (c.corner >= 0 || c.terms.size() != 1 || c.terms == speed.terms || KindOf(c) == WheelUnit::kUnknown) continue;
    const std::vector<double>& w = grid.Of(c);
    const Fit f = LinearFit(vg, w);
    if (f.n < 100 || !(f.corr > kWheelCorrelationMin)) continue;
    std::vector<double> ratio;
    for (size_t i = 0; i < w.size() && i < vg.size(); ++i)
      if (std::isfinite(vg[i]) && std::isfinite(w[i]) && w[i] != 0) ratio.push_back(vg[i] / w[i]);
    const double k = Percentile(ratio, 0.5);
    if (!std::isfinite(k)) continue;
    std::vector<double> dev(w.size(), NAN);
    for (size_t i = 0; i < w.size() && i < vg.size(); ++i) dev[i] = k * w[i] - vg[i];
    const Fit side = LinearFit(r, dev);
    if (side.n < 100 || !(std::fabs(side.corr) > kSideCorrelationMin)) continue;
    found.push_back({&c, f.corr, side.gain, side.corr});
  }
  // Both sides, one half-track: drop those whose |slope| is over 2x from the median |slope|.
  std::vector<double> mags;
  for (const auto& s : found) mags.push_back(std::fabs(s.slope));
  const double mid = Percentile(mags, 0.5);
  std::erase_if(found, [&](const SideWheel& s) { return !(std::fabs(s.slope) > 0.5 * mid && std::fabs(s.slope) < 2 * mid); });
  const bool left = std::any_of(found.begin(), found.end(), [](const SideWheel& s) { return s.slope < 0; });
  const bool right = std::any_of(found.begin(), found.end(), [](const SideWheel& s) { return s.slope > 0; });
  if (!left || !right) found.clear();
  return found;
}

// The wheels by side, in one kind of unit (the best correlated one's), as a WheelChoice.
WheelChoice WheelsWithoutCorners(Grid& grid, const std::vector<Source>& candidates, const Source& speed,
                                 const std::vector<double>& vg, const std::vector<double>& r) {
  WheelChoice w;
  const std::vector<SideWheel> sides = WheelsBySide(grid, candidates, speed, vg, r);
  if (sides.empty()) return w;
  const auto top = std::max_element(sides.begin(), sides.end(),
                                    [](const SideWheel& a, const SideWheel& b) { return a.corr_v < b.corr_v; });
  const WheelUnit kind = KindOf(*top->source);
  std::string list;
  for (const auto& s : sides) {
    if (KindOf(*s.source) != kind) continue;
    w.wheels.push_back(*s.source);
    w.corr.push_back(s.corr_v);
    list += fmt::format("{}{} (corr {:.4f} with the speed; deviation on r: slope {:+.3g}, corr {:+.2f})",
                        list.empty() ? "" : ", ", s.source->expression, s.corr_v, s.slope, s.corr_r);
  }
  w.text = fmt::format("wheel speeds without a corner in their names, told from other speeds by their deviation from the "
                       "vehicle speed following the bus's yaw rate (|corr| > {:.1f}, slopes of both signs: the two sides of "
                       "the car): {}",
                       kSideCorrelationMin, list);
  return w;
}

}  // namespace

WheelChoice ChooseWheels(Grid& grid, const std::vector<Source>& candidates, const Source& speed, double v99,
                         const Source* yaw) {
  WheelChoice w;
  if (candidates.empty() || !(v99 > 0)) return w;
  std::vector<double> vg = grid.Of(speed);
  for (double& x : vg)
    if (!(std::fabs(x) > 0.2 * v99)) x = NAN;
  // Per corner, the candidate that follows the vehicle speed best.
  const Source* best[4] = {nullptr, nullptr, nullptr, nullptr};
  double best_corr[4] = {0, 0, 0, 0};
  for (const auto& c : candidates) {
    if (c.corner < 0 || c.terms.size() != 1) continue;
    const Fit f = LinearFit(vg, grid.Of(c));
    if (f.n < 100 || f.corr <= best_corr[c.corner]) continue;
    best[c.corner] = &c;
    best_corr[c.corner] = f.corr;
  }
  // Those above the limit, all in the kind of unit of the best one.
  int top = -1;
  for (int k = 0; k < 4; ++k)
    if (best[k] && best_corr[k] > kWheelCorrelationMin && (top < 0 || best_corr[k] > best_corr[top])) top = k;
  std::string list;
  if (top >= 0) {
    const WheelUnit kind = KindOf(*best[top]);
    for (int k = 0; k < 4; ++k) {
      if (!best[k] || !(best_corr[k] > kWheelCorrelationMin) || KindOf(*best[k]) != kind) continue;
      w.wheels.push_back(*best[k]);
      w.corr.push_back(best_corr[k]);
      list += fmt::format("{}{} {} (corr {:.4f})", list.empty() ? "" : ", ", kCornerNames[k], best[k]->expression, best_corr[k]);
    }
  }
  std::string found_by = fmt::format("wheel speeds by correlation with the vehicle speed while moving (> {:.2f}): {}",
                                     kWheelCorrelationMin, list);
  if (w.wheels.size() < 2 && yaw != nullptr) {
    w = WheelsWithoutCorners(grid, candidates, speed, vg, grid.Of(*yaw));
    found_by = w.text;
  }
  if (w.wheels.size() < 2) {
    w.wheels.clear();
    return w;
  }
  w.rpm = KindOf(w.wheels.front()) == WheelUnit::kRpm;
  const std::vector<double> mean = MeanOf(grid, w.wheels);
  std::vector<double> ratio;
  for (size_t i = 0; i < mean.size(); ++i)
    if (std::isfinite(vg[i]) && std::fabs(mean[i]) > 0) ratio.push_back(vg[i] / mean[i]);
  if (ratio.size() < 100) {
    w.wheels.clear();
    return w;
  }
  w.ratio = Percentile(ratio, 0.5);
  const auto& su = SpeedUnits();
  const int wu = MatchUnit(su, w.wheels.front().unit);
  if (wu >= 0 && w.ratio != 0) w.factor = su[static_cast<size_t>(wu)].to_si / std::fabs(w.ratio);
  w.text = fmt::format("{}; speed / their mean = {:.4f} (median){}", found_by, w.ratio,
                       wu >= 0 ? fmt::format(", wheel speeds in {} by the DBC", su[static_cast<size_t>(wu)].name)
                       : w.rpm ? ", wheel speeds in 1/min by the DBC"
                               : "");
  return w;
}

namespace {

// The rear right minus the rear left wheel speed, where the names give both rear corners, in the
// unit (and with the factor) of the wheels' mean: with vehicle.track_rear_m a yaw-rate reference
// (stats/wheel_yaw.h) for the model choice. Wheels found by their sides alone give no rear pair.
// times: the mean's factor as written after its sum (" * 0.119883"), "" for a plain unit.
void ProposeRearDifference(const WheelChoice& w, const RoleProposal& mean, const std::string& times, InitResult& result) {
  const Source* corner[4] = {nullptr, nullptr, nullptr, nullptr};
  for (const auto& wh : w.wheels)
    if (wh.corner >= 0 && wh.corner < 4) corner[wh.corner] = &wh;
  if (!corner[2] || !corner[3]) return;
  RoleProposal p = mean;
  p.role = Role::kRearWheelSpeedDifference;
  p.evidence.clear();
  const std::string pair = corner[3]->expression + " - " + corner[2]->expression;
  p.expression = times.empty() ? pair : "(" + pair + ")" + times;
  p.evidence.push_back(fmt::format("the rear wheels by their names (RR {}, RL {}), right minus left in the unit of the wheels' "
                                   "mean: with vehicle.track_rear_m, a yaw-rate reference that tells a gyro scale from an "
                                   "accelerometer scale (the model_choice check)",
                                   corner[3]->expression, corner[2]->expression));
  result.roles.push_back(p);
}

}  // namespace

void ProposeWheelSpeed(const BusData& data, Grid& grid, const WheelChoice& w, const std::vector<double>& v_si,
                       InitResult& result) {
  if (w.wheels.size() < 2 || v_si.empty()) return;
  const RoleProposal& speed = RoleOf(result, Role::kSpeed);
  const std::vector<double> mean = MeanOf(grid, w.wheels);
  // v = k * mean through the origin, over moving samples: k in m/s per bus unit of the wheels.
  double svw = 0, sww = 0;
  std::vector<double> vm(v_si.size(), NAN);
  for (size_t i = 0; i < v_si.size() && i < mean.size(); ++i) {
    if (!(v_si[i] > kMovingWheels_mps) || !std::isfinite(mean[i])) continue;
    svw += v_si[i] * mean[i], sww += mean[i] * mean[i];
    vm[i] = v_si[i];
  }
  const Fit f = LinearFit(mean, vm);
  if (!(sww > 0) || f.n < 100 || !(f.corr > kWheelCorrelationMin)) return;
  const double k = svw / sww;
  const auto& su = SpeedUnits();
  RoleProposal p;
  p.role = Role::kWheelSpeed;
  SetSource(p, w.wheels.front(), data);
  for (const auto& wh : w.wheels) p.period_s = std::max(p.period_s, data.signals[static_cast<size_t>(wh.terms[0])].period_s);
  p.timeout_s = std::max(0.1, std::ceil(10.0 * p.period_s * 0.98 * 20.0) / 20.0);
  p.multi_signal = true;
  p.found = true;
  p.sign = 1;
  p.confidence = std::min(speed.confidence, f.corr);
  p.evidence.push_back(w.text);
  // A speed unit within 10 %: the plain mean in that unit. Otherwise (rotational speeds, or a
  // scale no unit explains) the mean times the fitted factor, in the vehicle speed's unit.
  size_t bu = 0;
  for (size_t i = 1; i < su.size(); ++i)
    if (std::fabs(std::log(su[i].to_si / k)) < std::fabs(std::log(su[bu].to_si / k))) bu = i;
  const std::string n = std::to_string(w.wheels.size());
  std::string times;  // the factor after the sum, shared with the rear difference
  if (!w.rpm && std::fabs(std::log(su[bu].to_si / k)) < std::log(1.1)) {
    p.expression = SumOf(w.wheels) + " / " + n;
    p.unit = su[bu].name;
    p.evidence.push_back(fmt::format("vehicle speed = {:.4f} × their mean in m/s per bus unit (corr {:.4f}, {} samples above "
                                     "{:.0f} m/s) → wheel speeds in {} (only for the plausibility check of vehicle_speed)",
                                     k, f.corr, f.n, kMovingWheels_mps, p.unit));
  } else {
    const int speed_unit = std::max(0, MatchUnit(su, speed.unit));
    const UnitOption& out = su[static_cast<size_t>(speed_unit)];
    const double factor = k / out.to_si;
    times = fmt::format(" * {:.6g}", factor);
    p.expression = SumOf(w.wheels) + times + " / " + n;
    p.unit = out.name;
    const std::string scale = w.rpm ? fmt::format("rolling radius {:.4f} m (1/min × 2π/60 × r = m/s)", k * 60.0 / (2.0 * M_PI))
                                    : fmt::format("{:.5g} m/s per bus unit (no speed unit within 10 %)", k);
    p.evidence.push_back(fmt::format("mean of the wheels regressed on the vehicle speed (corr {:.4f}, {} samples above {:.0f} "
                                     "m/s): {} → × {:.6g} gives {} (only for the plausibility check of vehicle_speed)",
                                     f.corr, f.n, kMovingWheels_mps, scale, factor, out.name));
  }
  result.roles.push_back(p);
  ProposeRearDifference(w, p, times, result);
}

}  // namespace ndsid::desk::init_detail
