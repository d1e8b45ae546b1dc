// `ndsid init`'s 20 Hz grid and fits (vehicle_init_detail.h): the steering's and a_x's, and the fallback for a bus
// without a yaw rate.
#include <spdlog/fmt/fmt.h>

#include <algorithm>
#include <cmath>

#include "ndsid/config/config.h"
#include "vehicle_init_detail.h"

namespace ndsid::desk::init_detail {

using config::Role;

// Least squares y = gain x + intercept over the pairs where both are finite.
Fit LinearFit(const std::vector<double>& x, const std::vector<double>& y) {
  double sx = 0, sy = 0, sxx = 0, syy = 0, sxy = 0;
  size_t n = 0;
  for (size_t i = 0; i < x.size(); ++i) {
    if (!std::isfinite(x[i]) || !std::isfinite(y[i])) continue;
    sx += x[i], sy += y[i], sxx += x[i] * x[i], syy += y[i] * y[i], sxy += x[i] * y[i];
    ++n;
  }
  Fit f;
  f.n = n;
  if (n < 20) return f;
  const double dn = static_cast<double>(n);
  const double vx = sxx - sx * sx / dn, vy = syy - sy * sy / dn, cxy = sxy - sx * sy / dn;
  if (vx <= 0 || vy <= 0) return f;
  f.gain = cxy / vx;
  f.intercept = (sy - f.gain * sx) / dn;
  f.corr = cxy / std::sqrt(vx * vy);
  const double resid_var = std::max(0.0, (vy - f.gain * cxy) / std::max(1.0, dn - 2));
  // Samples at 20 Hz are correlated over ~1 s: count 1 in 20 as independent.
  f.gain_se = std::sqrt(resid_var / vx) * std::sqrt(20.0);
  return f;
}

double Percentile(std::vector<double> v, double q) {
  v.erase(std::remove_if(v.begin(), v.end(), [](double x) { return !std::isfinite(x); }), v.end());
  if (v.empty()) return NAN;
  const size_t k = std::min(v.size() - 1, static_cast<size_t>(q * static_cast<double>(v.size() - 1)));
  std::nth_element(v.begin(), v.begin() + static_cast<std::ptrdiff_t>(k), v.end());
  return v[k];
}

std::vector<double> Abs(std::vector<double> v) {
  for (double& x : v) x = std::fabs(x);
  return v;
}

// Unit options of one role and a prior from the DBC's unit string.
std::vector<double> UnitPrior(const std::vector<UnitOption>& options, const std::string& dbc_unit) {
  const int known = MatchUnit(options, dbc_unit);
  std::vector<double> prior(options.size(), 1.0 / static_cast<double>(options.size()));
  if (known >= 0) {
    for (size_t i = 0; i < options.size(); ++i)
      prior[i] = static_cast<int>(i) == known ? 0.9 : 0.1 / static_cast<double>(options.size() - 1);
  }
  return prior;
}


std::string Pct(double p) { return fmt::format("{:.0f} %", 100.0 * p); }

Grid::Grid(const BusData& data, double rate_hz)
    : data_(data), rate_hz_(rate_hz), n_(static_cast<size_t>(std::max(0.0, (data.t1 - data.t0) * rate_hz)) + 1) {}

const std::vector<double>& Grid::OfSignal(int index) {
  auto it = signals_.find(index);
  if (it != signals_.end()) return it->second;
  const SignalSeries& s = data_.signals[static_cast<size_t>(index)];
  std::vector<double> g(n_, NAN);
  const double max_age = std::max(0.5, 5.0 * s.period_s);
  // Each grid point: the mean of the samples since the previous one (every sample counts: a
  // sensor vibrating faster than the grid is averaged, not aliased), else the last one held.
  size_t k = 0;
  for (size_t i = 0; i < n_; ++i) {
    const double t = data_.t0 + static_cast<double>(i) / rate_hz_;
    double sum = 0;
    size_t n = 0;
    for (; k < s.t.size() && s.t[k] <= t; ++k) sum += s.v[k], ++n;
    if (n > 0) g[i] = sum / static_cast<double>(n);
    else if (k > 0 && t - s.t[k - 1] <= max_age) g[i] = s.v[k - 1];
  }
  // Centred moving average over ~1 s: the relations init tests are quasi-static, the sensor
  // noise and quantisation are not (on the real RAV4 segment corr(a_y, v r) goes -0.35 -> -0.81).
  const size_t w = std::max<size_t>(1, static_cast<size_t>(std::lround(rate_hz_)));
  if (w > 1 && n_ > w) {
    std::vector<double> sm(n_, NAN);
    double sum = 0;
    size_t bad = 0;
    for (size_t i = 0; i < n_; ++i) {
      if (std::isfinite(g[i])) sum += g[i];
      else ++bad;
      if (i >= w) {
        if (std::isfinite(g[i - w])) sum -= g[i - w];
        else --bad;
      }
      if (i + 1 >= w && bad == 0) sm[i + 1 - w + w / 2] = sum / static_cast<double>(w);
    }
    g.swap(sm);
  }
  return signals_.emplace(index, std::move(g)).first->second;
}

const std::vector<double>& Grid::Of(const Source& s) {
  if (s.terms.size() == 1) return OfSignal(s.terms[0]);
  auto it = sources_.find(s.expression);
  if (it != sources_.end()) return it->second;
  std::vector<double> g = OfSignal(s.terms[0]);
  const std::vector<double>& b = OfSignal(s.terms[1]);
  for (size_t i = 0; i < g.size(); ++i) {
    switch (s.combine) {
      case Source::Combine::kSum: g[i] += b[i]; break;
      case Source::Combine::kDifference: g[i] -= b[i]; break;
      case Source::Combine::kSignMagnitude: g[i] *= 1.0 - 2.0 * b[i]; break;
      case Source::Combine::kSingle: break;
    }
  }
  return sources_.emplace(s.expression, std::move(g)).first->second;
}

namespace {

// What the steering signal reads, from the steer ratio a unit gives it (is = to_si / (|g| l)):
// a steering wheel's angle 10..25, the road wheels' angle about 1 (0.7..1.5: a research car's or a
// simulator's export). The log distance from the nearer of the two ranges, 0 inside it.
struct SteerReading {
  double distance;   // log distance of the steer ratio from its range
  bool road_wheels;  // the nearer range is the road wheels'
};

// The road wheels' range is the steer-ratio check's for them (config::PlausibilityConfig).
constexpr double kRoadMin = config::PlausibilityConfig::kRoadWheelSteerRatioMin;
constexpr double kRoadMax = config::PlausibilityConfig::kRoadWheelSteerRatioMax;

SteerReading ReadSteerRatio(double is) {
  const double wheel = std::max({0.0, std::log(10.0 / is), std::log(is / 25.0)});
  const double road = std::max({0.0, std::log(kRoadMin / is), std::log(is / kRoadMax)});
  return road < wheel ? SteerReading{road, true} : SteerReading{wheel, false};
}

std::string SteerRatioText(double is, bool road_wheels) {
  if (road_wheels)
    return is < kRoadMin || is > kRoadMax
               ? fmt::format("steer ratio {:.2f} outside {:g}..{:g}: check the unit", is, kRoadMin, kRoadMax)
               : fmt::format("steer ratio {:.2f}: the road wheels' angle, not the steering wheel's "
                             "(vehicle.steering_angle_at: road_wheels)", is);
  return is < 10.0 || is > 25.0 ? fmt::format("steer ratio {:.1f} outside 10..25: check the unit", is) : std::string();
}

}  // namespace

std::vector<double> ProposeWithoutYawRate(const BusData& data, Grid& grid, const std::vector<Source>& speed,
                                          const std::vector<Source>& lat, const std::vector<Source>& steer,
                                          const InitOptions& options, InitResult& result) {
  auto role = [&](Role r) -> RoleProposal& { return result.roles[static_cast<size_t>(r)]; };
  const auto& su = SpeedUnits();
  const auto& du = SteerUnits();
  const auto& au = AccelUnits();
  constexpr double kVch2 = kCharSpeed_mps * kCharSpeed_mps;
  // x = v^2 d / (1 + v^2/v_ch^2) with v in the unit `vu`, above 3 m/s (a_y against it, not a_y / v^2
  // against d: the fit's intercept then takes the accelerometer's offset).
  auto regressor = [&](const Source& v, size_t vu, const Source& d) {
    const auto& vg = grid.Of(v);
    const auto& dg = grid.Of(d);
    std::vector<double> x(vg.size(), NAN);
    for (size_t i = 0; i < vg.size(); ++i) {
      const double vs = vg[i] * su[vu].to_si;
      if (vs > kSteerMoving_mps && vs < 75.0) x[i] = vs * vs * dg[i] / (1.0 + vs * vs / kVch2);
    }
    return x;
  };
  struct Best {
    const Source *v = nullptr, *a = nullptr, *d = nullptr;
    Fit fit;
    double score = -1;
  } best;
  for (const auto& v : speed) {
    const int known = MatchUnit(su, v.unit);
    const size_t vu = known >= 0 ? static_cast<size_t>(known) : 0;
    for (const auto& d : steer) {
      const std::vector<double> x = regressor(v, vu, d);
      for (const auto& a : lat) {
        const Fit f = LinearFit(x, grid.Of(a));
        const double score = std::fabs(f.corr) + 0.01 * (v.name_score + a.name_score + d.name_score);
        if (f.n >= 100 && score > best.score) best = {&v, &a, &d, f, score};
      }
    }
  }
  if (best.v == nullptr || std::fabs(best.fit.corr) < 0.5) {
    if (best.v != nullptr)
      role(Role::kSteeringWheelAngle).reason = fmt::format(
          "no yaw rate, and the best (speed, a_y, steering) candidates ({}, {}, {}) do not follow a_y = v^2 d_sw / (is l (1 + "
          "v^2/v_ch^2)) (corr {:+.2f} < 0.5)",
          best.v->expression, best.a->expression, best.d->expression, best.fit.corr);
    return {};
  }
  // Units: a_y,raw = k x with k = f_d / (f_a is l); the steer ratio must be plausible (10..25).
  const double l = options.reference_wheelbase_m;
  const auto pv = UnitPrior(su, best.v->unit), pd = UnitPrior(du, best.d->unit), pa = UnitPrior(au, best.a->unit);
  const double v99 = Percentile(Abs(grid.Of(*best.v)), 0.99);
  const double a99 = Percentile(Abs(grid.Of(*best.a)), 0.99);
  double total = 0, top = -1, top_is = 0;
  bool top_road = false;
  size_t bv = 0, bd = 0, ba = 0;
  Fit bfit;
  std::vector<double> marg_v(su.size()), marg_d(du.size()), marg_a(au.size());
  for (size_t i = 0; i < su.size(); ++i) {
    const Fit f = LinearFit(regressor(*best.v, i, *best.d), grid.Of(*best.a));
    if (f.n < 100 || f.gain == 0) continue;
    for (size_t j = 0; j < du.size(); ++j)
      for (size_t m = 0; m < au.size(); ++m) {
        const double is = du[j].to_si / (au[m].to_si * std::fabs(f.gain) * l);
        const SteerReading reading = ReadSteerRatio(is);
        double w = pv[i] * pd[j] * pa[m] * Gauss(reading.distance / 0.25);
        if (v99 * su[i].to_si > 75.0 || v99 * su[i].to_si < 1.0) w *= 0.05;
        if (a99 * au[m].to_si > 15.0) w *= 0.05;
        if (!std::isfinite(w)) w = 0;
        total += w;
        marg_v[i] += w, marg_d[j] += w, marg_a[m] += w;
        if (w > top) top = w, bv = i, bd = j, ba = m, bfit = f, top_is = is, top_road = reading.road_wheels;
      }
  }
  if (!(total > 0)) return {};
  int dir = CommentDirection(best.d->comment);
  const int rel = bfit.gain > 0 ? 1 : -1;
  if (dir != 0) {
    result.notes.push_back(fmt::format("no yaw rate: ISO 8855 sign (steering positive to the left) taken from the comment of {} "
                                       "(confidence 90 %)",
                                       best.d->expression));
  } else {
    dir = 1;
    result.notes.push_back(
        "no yaw rate: ISO 8855 sign ASSUMED: the bus's steering angle is positive to the left (counter-clockwise); the DBC "
        "does not say. Check once in a left turn: steering and a_y must come out positive, else flip both signs "
        "(confidence 70 %)");
  }
  // Without a yaw rate there is no second relation to cross-check: confidence at most 60 %.
  const double cap = 0.6;
  auto fill = [&](Role r, const Source& s, const std::string& unit, double p_unit, int sign) {
    RoleProposal& p = role(r);
    p.found = true;
    SetSource(p, s, data);
    p.unit = unit;
    p.sign = sign;
    p.confidence = std::min({cap, p_unit, std::fabs(bfit.corr)});
    p.evidence.push_back(fmt::format(
        "no yaw rate: a_y = k v^2 d_sw / (1 + v^2/v_ch^2), v_ch = {:.0f} m/s, {} samples: corr {:+.3f}, k = {:.5g} ± {:.2g}; "
        "steer ratio {:.1f} with l = {:.2f} m for {} / {} / {} (posterior {})",
        kCharSpeed_mps, bfit.n, bfit.corr, bfit.gain, bfit.gain_se, top_is, l, su[bv].name, du[bd].name, au[ba].name,
        Pct(top / total)));
  };
  fill(Role::kSpeed, *best.v, su[bv].name, marg_v[bv] / total, 1);
  fill(Role::kSteeringWheelAngle, *best.d, du[bd].name, marg_d[bd] / total, dir);
  result.road_wheel_angle = top_road;
  if (const std::string text = SteerRatioText(top_is, top_road); !text.empty()) role(Role::kSteeringWheelAngle).evidence.push_back(text);
  fill(Role::kLateralAcceleration, *best.a, au[ba].name, marg_a[ba] / total, dir * rel);
  if (!best.d->pair_evidence.empty()) role(Role::kSteeringWheelAngle).evidence.push_back(best.d->pair_evidence);
  std::vector<double> v_si = grid.Of(*best.v);
  for (double& x : v_si) x *= su[bv].to_si;
  return v_si;
}

std::vector<double> MedianFilter(const std::vector<double>& x, size_t width) {
  std::vector<double> out(x.size(), NAN), window;
  const size_t h = width / 2;
  for (size_t i = 0; i < x.size(); ++i) {
    window.clear();
    for (size_t j = i >= h ? i - h : 0; j <= i + h && j < x.size(); ++j)
      if (std::isfinite(x[j])) window.push_back(x[j]);
    if (2 * window.size() <= width) continue;
    std::nth_element(window.begin(), window.begin() + static_cast<std::ptrdiff_t>(window.size() / 2), window.end());
    out[i] = window[window.size() / 2];
  }
  return out;
}

void ProposeSteering(const BusData& data, Grid& grid, const Source& yaw, double yaw_to_iso, const std::vector<double>& v_si,
                     const std::vector<Source>& steer, const InitOptions& options, InitResult& result) {
  // kappa (1 + v^2/v_ch^2) from the ISO yaw rate, over moving samples; 0.5 s medians (11 points
  // at 20 Hz) so that neither noise spikes nor a few bad frames decide.
  const size_t median_width = 2 * static_cast<size_t>(std::lround(0.25 * kGrid_hz)) + 1;
  const std::vector<double>& rg = grid.Of(yaw);
  std::vector<double> y(rg.size(), NAN);
  for (size_t i = 0; i < rg.size(); ++i) {
    if (!(v_si[i] > kSteerMoving_mps)) continue;
    y[i] = rg[i] * yaw_to_iso / v_si[i] * (1.0 + (v_si[i] * v_si[i]) / (kCharSpeed_mps * kCharSpeed_mps));
  }
  y = MedianFilter(y, median_width);
  struct SteerFit {
    const Source* s = nullptr;
    Fit fit;
    double score = -1;
  } bs;
  std::vector<std::pair<const Source*, Fit>> steer_fits;
  for (const auto& s : steer) {
    std::vector<double> x = MedianFilter(grid.Of(s), median_width);
    for (size_t i = 0; i < x.size(); ++i)
      if (!std::isfinite(y[i])) x[i] = NAN;
    const Fit f = LinearFit(x, y);
    steer_fits.emplace_back(&s, f);
    const double score = std::fabs(f.corr) + 0.01 * s.name_score;
    if (f.n >= 100 && score > bs.score) bs = {&s, f, score};
  }
  RoleProposal& p = RoleOf(result, Role::kSteeringWheelAngle);
  if (!(bs.s != nullptr && std::fabs(bs.fit.corr) >= 0.5)) {
    p.reason = bs.s == nullptr ? "too little driving above 3 m/s to test r / v = d_sw / (is l)"
                               : fmt::format("best candidate {} does not follow r / v = d_sw / (is l) (corr {:+.2f} < 0.5)",
                                             bs.s->expression, bs.fit.corr);
    return;
  }
  const auto& units = SteerUnits();
  const auto prior = UnitPrior(units, bs.s->unit);
  const double l = options.reference_wheelbase_m;
  std::vector<double> w(units.size());
  double total = 0;
  for (size_t i = 0; i < units.size(); ++i) {
    w[i] = prior[i] * Gauss(ReadSteerRatio(units[i].to_si / (std::fabs(bs.fit.gain) * l)).distance / 0.25);
    total += w[i];
  }
  const size_t bu = static_cast<size_t>(std::max_element(w.begin(), w.end()) - w.begin());
  const double is = units[bu].to_si / (std::fabs(bs.fit.gain) * l);
  const int rel = bs.fit.gain > 0 ? 1 : -1;
  p.found = true;
  SetSource(p, *bs.s, data);
  p.unit = units[bu].name;
  p.sign = rel;  // r_si is already ISO 8855 (times sr)
  const double p_unit = total > 0 ? w[bu] / total : 0;
  p.confidence = std::min({p_unit, std::fabs(bs.fit.corr), RoleOf(result, Role::kYawRate).confidence});
  p.evidence.push_back(fmt::format(
      "kappa (1 + v^2/v_ch^2) = g d_sw with kappa = r / v, v_ch = {:.0f} m/s, v > {:.0f} m/s, 0.5 s medians, {} samples: "
      "corr {:+.3f}, g = {:.5g} ± {:.2g}",
      kCharSpeed_mps, kSteerMoving_mps, bs.fit.n, bs.fit.corr, bs.fit.gain, bs.fit.gain_se));
  p.evidence.push_back(fmt::format("steer ratio with l = {:.2f} m: {:.1f} if {}, {:.1f} if {} → {} (posterior {}; DBC says '{}')", l,
                                   units[0].to_si / (std::fabs(bs.fit.gain) * l), units[0].name,
                                   units[1].to_si / (std::fabs(bs.fit.gain) * l), units[1].name, p.unit, Pct(p_unit),
                                   bs.s->unit));
  p.evidence.push_back(fmt::format("sign of g {} against the ISO yaw rate → sign {:+d}", rel > 0 ? "+" : "−", rel));
  if (!bs.s->pair_evidence.empty()) {
    double single = NAN;  // the same fit with the first signal alone
    for (const auto& [src, fit] : steer_fits)
      if (src->terms.size() == 1 && src->terms[0] == bs.s->terms[0]) single = fit.corr;
    p.evidence.push_back(std::isfinite(single) ? fmt::format("{}: corr {:+.3f} against {:+.3f} for {} alone", bs.s->pair_evidence,
                                                             bs.fit.corr, single, p.message + "." + p.signal)
                                               : bs.s->pair_evidence);
  }
  result.road_wheel_angle = ReadSteerRatio(is).road_wheels;
  if (const std::string text = SteerRatioText(is, result.road_wheel_angle); !text.empty()) p.evidence.push_back(text);
}

void ProposeLongitudinal(const BusData& data, Grid& grid, const std::vector<double>& v_si, const std::vector<Source>& lon,
                         InitResult& result) {
  RoleProposal& px = RoleOf(result, Role::kLongitudinalAcceleration);
  if (v_si.empty() || lon.empty()) {
    if (px.reason.empty()) {
      px.reason = lon.empty() ? "no varying signal named like a longitudinal acceleration (accel_x/long/laengs)"
                              : "needs the speed confirmed first";
    }
    return;
  }
  const size_t h = 5;  // +-0.25 s central difference
  std::vector<double> dv(v_si.size(), NAN);
  for (size_t i = h; i + h < v_si.size(); ++i)
    if (v_si[i] > 2.0) dv[i] = (v_si[i + h] - v_si[i - h]) * kGrid_hz / static_cast<double>(2 * h);
  const Source* bx = nullptr;
  Fit fx;
  for (const auto& s : lon) {
    const Fit f = LinearFit(dv, grid.Of(s));
    if (f.n >= 100 && (bx == nullptr || std::fabs(f.corr) > std::fabs(fx.corr))) bx = &s, fx = f;
  }
  if (!(bx != nullptr && std::fabs(fx.corr) >= 0.5)) {
    px.reason = bx == nullptr ? "no candidate with enough driving" : fmt::format("best candidate {} does not follow dv/dt (corr {:+.2f})", bx->expression, fx.corr);
    return;
  }
  const auto& units = AccelUnits();
  const auto prior = UnitPrior(units, bx->unit);
  std::vector<double> w(units.size());
  double total = 0;
  for (size_t i = 0; i < units.size(); ++i) total += w[i] = prior[i] * Gauss(std::log(std::fabs(fx.gain) * units[i].to_si) / 0.2);
  const size_t bu = static_cast<size_t>(std::max_element(w.begin(), w.end()) - w.begin());
  px.found = true;
  SetSource(px, *bx, data);
  px.unit = units[bu].name;
  px.sign = fx.gain > 0 ? 1 : -1;
  px.confidence = std::min(std::fabs(fx.corr), total > 0 ? w[bu] / total : 0);
  px.evidence.push_back(fmt::format("a_x = k dv/dt over {} samples: corr {:+.3f}, k = {:.4g} (1 if m/s^2, 0.102 if g) → {} sign {:+d}",
                                    fx.n, fx.corr, fx.gain, px.unit, px.sign));
}

}  // namespace ndsid::desk::init_detail
