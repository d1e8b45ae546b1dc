// `ndsid init`'s analysis (see vehicle_init.h for the physics). Steps: decode every signal of
// the DBC from the whole log; candidates per role from names/units/comments; resample onto a
// 20 Hz grid; joint choice of (v, r, a_y) by the correlation of a_y with v r and a posterior over
// the unit combinations; the steering candidate (and coarse+fine or sign+magnitude pairs) by the
// correlation of r with v d_sw / (1 + v^2/v_ch^2); a_x by dv/dt.
#include "vehicle_init.h"

#include <algorithm>
#include <cmath>
#include <map>
#include <unordered_map>

#include <spdlog/fmt/fmt.h>
#include "ndsid/common/error.h"
#include "ndsid/dbc/decoder.h"
#include "vehicle_init_detail.h"

namespace ndsid::desk {

using config::Role;
using namespace init_detail;

const RoleProposal* InitResult::Find(Role role) const {
  for (const auto& r : roles)
    if (r.role == role) return &r;
  return nullptr;
}

bool InitResult::MandatoryFound() const {
  for (Role role : {Role::kSteeringWheelAngle, Role::kSpeed, Role::kLateralAcceleration}) {
    const RoleProposal* p = Find(role);
    if (p == nullptr || !p->found) return false;
  }
  return true;
}

namespace {

constexpr double kMoving_mps = 5.0;
constexpr size_t kTopCandidates = 4;

}  // namespace

InitResult ProposeVehicleConfig(const dbc::Database& db, can::FrameLog& log, const InitOptions& options) {
  InitResult result;
  BusData data = CollectSignals(db, log, options.bus, options.max_frames, result.frames, result.truncated);
  if (data.signals.empty()) throw ConfigError(db.file + ": no frame of the log decodes with this DBC (wrong DBC or bus?)");
  result.log_duration_s = data.t1 - data.t0;
  Grid grid(data, kGrid_hz);

  for (int r = 0; r <= static_cast<int>(Role::kLongitudinalAcceleration); ++r) {
    RoleProposal p;
    p.role = static_cast<Role>(r);
    result.roles.push_back(p);
  }
  auto role = [&](Role r) -> RoleProposal& { return result.roles[static_cast<size_t>(r)]; };

  std::vector<Source> speed = Candidates(data, RoleKind::kSpeed, 2 * kTopCandidates);
  std::vector<Source> yaw = Candidates(data, RoleKind::kYawRate, kTopCandidates);
  std::vector<Source> lat = Candidates(data, RoleKind::kLatAccel, kTopCandidates);
  std::vector<Source> steer = Candidates(data, RoleKind::kSteer, 2 * kTopCandidates);
  std::vector<Source> lon = Candidates(data, RoleKind::kLongAccel, kTopCandidates);
  std::vector<Source> wheels = Candidates(data, RoleKind::kWheelSpeed, 8);

  if (speed.empty()) role(Role::kSpeed).reason = "no varying signal named like a vehicle speed (speed/velocity/geschw, km/h|m/s|mph)";
  if (yaw.empty()) role(Role::kYawRate).reason = "no varying signal named like a yaw rate (yaw/gier)";
  if (lat.empty()) role(Role::kLateralAcceleration).reason = "no varying signal named like a lateral acceleration (accel_y/lat/quer)";
  if (steer.empty()) role(Role::kSteeringWheelAngle).reason = "no varying signal named like a steering-wheel angle (steer/lenk + angle/winkel)";

  // 1. (v, r, a_y): a_y = k v r. The best correlated triple among the named candidates.
  struct Triple {
    const Source *v = nullptr, *r = nullptr, *a = nullptr;
    Fit fit;
    double score = -1;
  } best;
  for (const auto& v : speed) {
    const std::vector<double>& vg = grid.Of(v);
    const double v99 = Percentile(Abs(vg), 0.99);
    if (!(v99 > 0)) continue;
    for (const auto& r : yaw) {
      const std::vector<double>& rg = grid.Of(r);
      std::vector<double> vr(vg.size(), NAN);
      for (size_t i = 0; i < vg.size(); ++i)
        if (std::fabs(vg[i]) > 0.2 * v99) vr[i] = vg[i] * rg[i];
      for (const auto& a : lat) {
        const Fit f = LinearFit(vr, grid.Of(a));
        const double score = std::fabs(f.corr) + 0.01 * (v.name_score + r.name_score + a.name_score);
        if (f.n >= 100 && score > best.score) best = {&v, &r, &a, f, score};
      }
    }
  }
  double sr = 1;  // the sign that makes the yaw rate ISO 8855 (positive left)
  double fv = NAN, fr = NAN, fa = NAN;  // chosen unit factors to SI
  std::vector<double> v_si;
  if (best.v != nullptr && std::fabs(best.fit.corr) >= 0.5) {
    // Posterior over the 12 unit combinations: gain k = fv fr / fa.
    const auto& su = SpeedUnits();
    const auto& yu = YawUnits();
    const auto& au = AccelUnits();
    const auto pv = UnitPrior(su, best.v->unit), pr = UnitPrior(yu, best.r->unit), pa = UnitPrior(au, best.a->unit);
    const double v99 = Percentile(Abs(grid.Of(*best.v)), 0.99);
    const double r99 = Percentile(Abs(grid.Of(*best.r)), 0.99);
    const double a99 = Percentile(Abs(grid.Of(*best.a)), 0.99);
    // Speed against the mean of the wheel speeds, where present.
    double wheel_ratio = NAN, wheel_factor = NAN;
    std::string wheel_text;
    if (!wheels.empty()) {
      std::vector<double> mean(grid.size(), 0.0);
      for (const auto& w : wheels) {
        const auto& wg = grid.Of(w);
        for (size_t i = 0; i < mean.size(); ++i) mean[i] += wg[i] / static_cast<double>(wheels.size());
      }
      const auto& vg = grid.Of(*best.v);
      std::vector<double> ratio;
      for (size_t i = 0; i < mean.size(); ++i)
        if (std::fabs(vg[i]) > 0.2 * v99 && std::fabs(mean[i]) > 0) ratio.push_back(vg[i] / mean[i]);
      if (ratio.size() >= 100) {
        wheel_ratio = Percentile(ratio, 0.5);
        const int wu = MatchUnit(su, wheels.front().unit);
        if (wu >= 0 && wheel_ratio != 0) wheel_factor = su[static_cast<size_t>(wu)].to_si / std::fabs(wheel_ratio);
        wheel_text = fmt::format("speed / mean of {} wheel speeds ({}) = {:.4f} (median while moving){}", wheels.size(),
                                 wheels.front().expression, wheel_ratio,
                                 wu >= 0 ? fmt::format("; wheel speeds in {} by the DBC", su[static_cast<size_t>(wu)].name) : "");
      }
    }
    const double k = std::fabs(best.fit.gain);
    const double sigma = std::hypot(0.1, best.fit.gain_se / k);
    double total = 0, top = -1;
    size_t bv = 0, br = 0, ba = 0;
    std::vector<double> marg_v(su.size()), marg_r(yu.size()), marg_a(au.size());
    for (size_t i = 0; i < su.size(); ++i)
      for (size_t j = 0; j < yu.size(); ++j)
        for (size_t l = 0; l < au.size(); ++l) {
          const double kc = su[i].to_si * yu[j].to_si / au[l].to_si;
          double w = pv[i] * pr[j] * pa[l] * Gauss(std::log(k / kc) / sigma);
          const double vmax = v99 * su[i].to_si, rmax = r99 * yu[j].to_si, amax = a99 * au[l].to_si;
          if (vmax > 75.0 || vmax < 1.0) w *= 0.05;  // 4..270 km/h is where cars drive
          if (rmax > 1.5) w *= 0.05;                 // 86 deg/s
          if (amax > 15.0) w *= 0.05;
          if (std::isfinite(wheel_factor)) w *= Gauss(std::log(su[i].to_si / wheel_factor) / 0.05);
          if (!std::isfinite(w)) w = 0;
          total += w;
          marg_v[i] += w, marg_r[j] += w, marg_a[l] += w;
          if (w > top) top = w, bv = i, br = j, ba = l;
        }
    fv = su[bv].to_si, fr = yu[br].to_si, fa = au[ba].to_si;
    const bool plausible = total > 0;  // else every combination is implausible: confidence 0, CHECK
    if (!plausible) total = 1;
    const double p_combo = top / total;
    const double kc = fv * fr / fa;

    // The absolute convention: the DBC's comments, else the usual bus convention.
    const int rel_a = best.fit.gain > 0 ? 1 : -1;
    int dir = CommentDirection(best.r->comment);
    std::string from = "the comment of " + best.r->expression;
    if (dir == 0 && (dir = CommentDirection(best.a->comment)) != 0) {
      dir *= rel_a;
      from = "the comment of " + best.a->expression;
    }
    double p_abs = 0.9;
    if (dir != 0) {
      sr = dir;
      result.notes.push_back(fmt::format("ISO 8855 sign (yaw rate positive to the left) taken from {} (confidence 90 %)", from));
    } else {
      sr = 1;
      p_abs = 0.7;
      result.notes.push_back(
          "ISO 8855 sign ASSUMED: the bus's yaw rate is positive to the left (counter-clockwise seen from above, as on "
          "most buses); the DBC does not say and the data cannot tell left from right. Check once: in a left turn the "
          "yaw rate must come out positive, else flip the sign of yaw_rate, lateral_acceleration and "
          "steering_wheel_angle together (confidence 70 %)");
    }
    const double p_rel = std::min(0.99, std::fabs(best.fit.corr));
    auto fill = [&](RoleProposal& p, const Source& s, const std::string& unit, double p_unit, int sign) {
      p.found = true;
      SetSource(p, s, data);
      p.unit = unit;
      p.sign = sign;
      p.confidence = std::min(p_unit, std::fabs(best.fit.corr));
      if (!plausible) p.evidence.push_back("no unit combination fits the gain within the plausible ranges");
    };
    // Speed forward positive: a bus that counts it negative (rare) gets sign -1.
    std::vector<double> moving_v;
    for (double x : grid.Of(*best.v))
      if (std::isfinite(x) && std::fabs(x) > 0.2 * v99) moving_v.push_back(x);
    const int v_sign = !moving_v.empty() && Percentile(moving_v, 0.5) < 0 ? -1 : 1;
    fill(role(Role::kSpeed), *best.v, su[bv].name, marg_v[bv] / total, v_sign);
    fill(role(Role::kYawRate), *best.r, yu[br].name, marg_r[br] / total, static_cast<int>(sr));
    fill(role(Role::kLateralAcceleration), *best.a, au[ba].name, marg_a[ba] / total, static_cast<int>(sr) * rel_a);
    role(Role::kYawRate).confidence = std::min(role(Role::kYawRate).confidence, p_abs);
    role(Role::kLateralAcceleration).confidence = std::min({role(Role::kLateralAcceleration).confidence, p_abs, p_rel});
    const std::string fit_text =
        fmt::format("a_y = k v r over {} samples at {:.0f} Hz: corr {:+.3f}, k = {:.5g} ± {:.2g} (bus units); "
                    "{} × {} / {} predicts {:.5g} (ratio {:.3f}); unit combination posterior {}",
                    best.fit.n, kGrid_hz, best.fit.corr, best.fit.gain, best.fit.gain_se, su[bv].name, yu[br].name,
                    au[ba].name, kc, k / kc, Pct(p_combo));
    for (Role rl : {Role::kSpeed, Role::kYawRate, Role::kLateralAcceleration}) role(rl).evidence.push_back(fit_text);
    role(Role::kLateralAcceleration)
        .evidence.push_back(fmt::format("sign of k {} → a_y has {} sign as the yaw rate", rel_a > 0 ? "+" : "−",
                                        rel_a > 0 ? "the same" : "the opposite"));
    role(Role::kSpeed).evidence.push_back(
        fmt::format("unit {} (posterior {}; DBC says '{}'); p99 = {:.1f} m/s", su[bv].name, Pct(marg_v[bv] / total),
                    best.v->unit, v99 * fv));
    role(Role::kYawRate).evidence.push_back(fmt::format("unit {} (posterior {}; DBC says '{}'); p99 |r| = {:.3f} rad/s",
                                                        yu[br].name, Pct(marg_r[br] / total), best.r->unit, r99 * fr));
    role(Role::kLateralAcceleration)
        .evidence.push_back(fmt::format("unit {} (posterior {}; DBC says '{}'); p99 |a_y| = {:.2f} m/s^2", au[ba].name,
                                        Pct(marg_a[ba] / total), best.a->unit, a99 * fa));
    if (!wheel_text.empty()) role(Role::kSpeed).evidence.push_back(wheel_text);
    // The wheel speeds' mean as the optional wheel_speed role (the speed's plausibility check),
    // its unit from the speed's and the measured ratio (speed = ratio * mean of the wheels).
    const bool single_wheels = std::all_of(wheels.begin(), wheels.end(), [](const Source& w) { return w.terms.size() == 1; });
    if (std::isfinite(wheel_ratio) && wheels.size() >= 2 && wheels.size() <= 4 && single_wheels) {
      const double w_si = fv * std::fabs(wheel_ratio);
      size_t bu = 0;
      for (size_t i = 1; i < su.size(); ++i)
        if (std::fabs(std::log(su[i].to_si / w_si)) < std::fabs(std::log(su[bu].to_si / w_si))) bu = i;
      if (std::fabs(std::log(su[bu].to_si / w_si)) < std::log(1.1)) {
        RoleProposal p;
        p.role = Role::kWheelSpeed;
        SetSource(p, wheels.front(), data);
        std::string sum;
        for (const auto& w : wheels) sum += (sum.empty() ? "" : " + ") + w.expression;
        p.expression = fmt::format("({}) / {}", sum, wheels.size());
        p.multi_signal = true;
        for (const auto& w : wheels) {
          const SignalSeries& ws = data.signals[static_cast<size_t>(w.terms[0])];
          p.period_s = std::max(p.period_s, ws.period_s);
        }
        p.found = true;
        p.unit = su[bu].name;
        p.sign = 1;
        p.confidence = role(Role::kSpeed).confidence;
        p.evidence.push_back(wheel_text + fmt::format(" → wheel speeds in {} (only for the plausibility check of vehicle_speed)",
                                                      su[bu].name));
        result.roles.push_back(p);
      }
    }
    if (!best.r->pair_evidence.empty()) role(Role::kYawRate).evidence.push_back(best.r->pair_evidence);
    if (!best.a->pair_evidence.empty()) role(Role::kLateralAcceleration).evidence.push_back(best.a->pair_evidence);
    v_si = grid.Of(*best.v);
    for (double& x : v_si) x *= fv * v_sign;
  } else {
    const std::string why = best.v == nullptr
                                ? "no (speed, yaw rate, a_y) candidates to test a_y = v r with"
                                : fmt::format("the best candidates ({}, {}, {}) do not follow a_y = v r (corr {:+.2f} < 0.5)",
                                              best.v->expression, best.r->expression, best.a->expression, best.fit.corr);
    for (Role rl : {Role::kSpeed, Role::kYawRate, Role::kLateralAcceleration})
      if (role(rl).reason.empty()) role(rl).reason = why;
  }

  // 1b. No yaw rate confirmed: a_y = v^2 d_sw / (is l (1 + v^2/v_ch^2)) instead.
  const bool yaw_found = !v_si.empty();
  if (!yaw_found && !speed.empty() && !lat.empty() && !steer.empty()) {
    v_si = ProposeWithoutYawRate(data, grid, speed, lat, steer, options, result);
    if (!v_si.empty())
      for (Role rl : {Role::kSpeed, Role::kLateralAcceleration}) role(rl).reason.clear();
  }
  size_t moving = 0;
  for (double x : v_si) moving += std::isfinite(x) && x > kMoving_mps;
  result.moving_s = static_cast<double>(moving) / kGrid_hz;

  // 2. Steering: r = g v d / (1 + v^2/v_ch^2) at low lateral acceleration.
  if (yaw_found && !steer.empty()) {
    std::vector<double> r_si = grid.Of(*best.r), a_si = grid.Of(*best.a);
    for (double& x : r_si) x *= fr * sr;
    for (double& x : a_si) x *= fa;
    struct SteerFit {
      const Source* s = nullptr;
      Fit fit;
      double score = -1;
    } bs;
    std::vector<std::pair<const Source*, Fit>> steer_fits;
    for (const auto& s : steer) {
      const auto& dg = grid.Of(s);
      std::vector<double> x(dg.size(), NAN);
      for (size_t i = 0; i < dg.size(); ++i)
        if (v_si[i] > 4.0 && std::fabs(a_si[i]) < 2.0)
          x[i] = v_si[i] * dg[i] / (1.0 + (v_si[i] * v_si[i]) / (kCharSpeed_mps * kCharSpeed_mps));
      const Fit f = LinearFit(x, r_si);
      steer_fits.emplace_back(&s, f);
      const double score = std::fabs(f.corr) + 0.01 * s.name_score;
      if (f.n >= 100 && score > bs.score) bs = {&s, f, score};
    }
    RoleProposal& p = role(Role::kSteeringWheelAngle);
    if (bs.s != nullptr && std::fabs(bs.fit.corr) >= 0.5) {
      const auto& units = SteerUnits();
      const auto prior = UnitPrior(units, bs.s->unit);
      const double l = options.reference_wheelbase_m;
      std::vector<double> w(units.size());
      double total = 0;
      for (size_t i = 0; i < units.size(); ++i) {
        const double is = units[i].to_si / (std::fabs(bs.fit.gain) * l);
        const double d = std::max({0.0, std::log(10.0 / is), std::log(is / 25.0)});
        w[i] = prior[i] * Gauss(d / 0.25);
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
      p.confidence = std::min({p_unit, std::fabs(bs.fit.corr), role(Role::kYawRate).confidence});
      p.evidence.push_back(fmt::format(
          "r = g v d_sw / (1 + v^2/v_ch^2), v_ch = {:.0f} m/s, |a_y| < 2 m/s^2, {} samples: corr {:+.3f}, g = {:.5g} ± {:.2g}",
          kCharSpeed_mps, bs.fit.n, bs.fit.corr, bs.fit.gain, bs.fit.gain_se));
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
      if (is < 10.0 || is > 25.0) p.evidence.push_back(fmt::format("steer ratio {:.1f} outside 10..25: check the unit", is));
    } else {
      p.reason = bs.s == nullptr ? "too little driving above 4 m/s to test r = v d_sw / (is l)"
                                 : fmt::format("best candidate {} does not follow r = v d_sw / (is l) (corr {:+.2f} < 0.5)",
                                               bs.s->expression, bs.fit.corr);
    }
  } else if (!role(Role::kSteeringWheelAngle).found && role(Role::kSteeringWheelAngle).reason.empty()) {
    role(Role::kSteeringWheelAngle).reason = "needs the speed and yaw rate (r = v d_sw / (is l)) or a_y (a_y = v^2 d_sw / (is l)) confirmed first";
  }

  // 3. a_x = dv/dt.
  RoleProposal& px = role(Role::kLongitudinalAcceleration);
  if (!v_si.empty() && !lon.empty()) {
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
    if (bx != nullptr && std::fabs(fx.corr) >= 0.5) {
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
    } else {
      px.reason = bx == nullptr ? "no candidate with enough driving" : fmt::format("best candidate {} does not follow dv/dt (corr {:+.2f})", bx->expression, fx.corr);
    }
  } else if (px.reason.empty()) {
    px.reason = lon.empty() ? "no varying signal named like a longitudinal acceleration (accel_x/long/laengs)"
                            : "needs the speed confirmed first";
  }

  // The bus: the one all found roles are on, if the log has several.
  std::string bus;
  bool one = true;
  for (const auto& p : result.roles) {
    if (!p.found) continue;
    const std::string& b = data.BusOf(p.message);
    if (bus.empty()) bus = b;
    else if (b != bus) one = false;
  }
  if (one && data.bus_names.size() > 1) result.bus = bus;
  return result;
}

}  // namespace ndsid::desk
