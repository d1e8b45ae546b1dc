// `ndsid init`'s analysis (see vehicle_init.h for the physics). Steps: decode every signal of
// the DBC from the whole log; candidates per role from names/units/comments; resample onto a
// 20 Hz grid; joint choice of (v, r, a_y) by the correlation of a_y with v r and a posterior over
// the unit combinations; the steering candidate (and coarse+fine or sign+magnitude pairs) by the
// correlation of r with v d_sw / (1 + v^2/v_ch^2); a_x by dv/dt. ProposeVehicleConfig calls
// them in order; the steering's and a_x's fits are in vehicle_init_fit.cc.
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

// The varying signals named like each role (Candidates), best names first.
struct RoleCandidates {
  std::vector<Source> speed, yaw, lat, steer, lon, wheels;
};

RoleCandidates FindCandidates(const BusData& data, InitResult& result) {
  RoleCandidates c;
  c.speed = Candidates(data, RoleKind::kSpeed, 2 * kTopCandidates);
  c.yaw = Candidates(data, RoleKind::kYawRate, kTopCandidates);
  c.lat = Candidates(data, RoleKind::kLatAccel, kTopCandidates);
  c.steer = Candidates(data, RoleKind::kSteer, 2 * kTopCandidates);
  c.lon = Candidates(data, RoleKind::kLongAccel, kTopCandidates);
  c.wheels = Candidates(data, RoleKind::kWheelSpeed, 32);
  if (c.speed.empty()) RoleOf(result, Role::kSpeed).reason = "no varying signal named like a vehicle speed (speed/velocity/geschw, km/h|m/s|mph)";
  if (c.yaw.empty()) RoleOf(result, Role::kYawRate).reason = "no varying signal named like a yaw rate (yaw/gier)";
  if (c.lat.empty()) RoleOf(result, Role::kLateralAcceleration).reason = "no varying signal named like a lateral acceleration (accel_y/lat/quer)";
  if (c.steer.empty()) RoleOf(result, Role::kSteeringWheelAngle).reason = "no varying signal named like a steering-wheel angle (steer/lenk + angle/winkel)";
  return c;
}

// Step 1's candidates: the (v, r, a_y) triple that best follows a_y = k v r.
struct Triple {
  const Source *v = nullptr, *r = nullptr, *a = nullptr;
  Fit fit;          // a_y against v r
  double score = -1;  // |corr| plus a little for good names
};

// v r on the grid where |v| is above `fraction` of its 99th percentile (NaN elsewhere).
std::vector<double> SpeedTimesYaw(Grid& grid, const Source& v, const Source& r, double fraction) {
  const std::vector<double>& vg = grid.Of(v);
  const std::vector<double>& rg = grid.Of(r);
  const double v99 = Percentile(Abs(vg), 0.99);
  std::vector<double> vr(vg.size(), NAN);
  for (size_t i = 0; i < vg.size(); ++i)
    if (std::fabs(vg[i]) > fraction * v99) vr[i] = vg[i] * rg[i];
  return vr;
}

constexpr double kKinematicSpeedFraction = 0.2;  // a_y = k v r above 20 % of the speed's 99th percentile

Triple BestKinematicTriple(Grid& grid, const RoleCandidates& c) {
  Triple best;
  for (const auto& v : c.speed) {
    if (!(Percentile(Abs(grid.Of(v)), 0.99) > 0)) continue;
    for (const auto& r : c.yaw) {
      const std::vector<double> vr = SpeedTimesYaw(grid, v, r, kKinematicSpeedFraction);
      for (const auto& a : c.lat) {
        const Fit f = LinearFit(vr, grid.Of(a));
        const double score = std::fabs(f.corr) + 0.01 * (v.name_score + r.name_score + a.name_score);
        if (f.n >= 100 && score > best.score) best = {&v, &r, &a, f, score};
      }
    }
  }
  return best;
}

// How far the gain of a_y = k v r is from the nearest unit combination's prediction (|log|).
double UnitDistance(double gain) {
  double d = INFINITY;
  for (const auto& v : SpeedUnits())
    for (const auto& r : YawUnits())
      for (const auto& a : AccelUnits()) d = std::min(d, std::fabs(std::log(std::fabs(gain) * a.to_si / (v.to_si * r.to_si))));
  return d;
}

// A scaled copy of the chosen speed (a speedometer's, a few % high) follows a_y = k v r as well:
// among the copies (correlation above 0.995 with it), the speed is the one whose gain lies
// nearest a unit combination's prediction (a_y = v r holds in SI), when nearer by a margin the
// data resolve. Says so in `evidence`.
void PreferUnscaledSpeed(Grid& grid, const RoleCandidates& c, Triple& best, std::string& evidence) {
  if (best.v == nullptr) return;
  // a_y = k v r down to a tenth of the top speed: at higher speeds the body's sideslip rate
  // (a_y = v (r + beta')) tilts k by a percent or two, as much as a speedometer's bias.
  auto gain = [&](const Source& v) { return LinearFit(SpeedTimesYaw(grid, v, *best.r, 0.1), grid.Of(*best.a)); };
  const std::vector<double> chosen = grid.Of(*best.v);
  const Fit own = gain(*best.v);
  double dist = UnitDistance(own.gain);
  // A copy wins only by more than the model's percent and twice the gain's standard error.
  const double margin = std::max(0.01, 2.0 * own.gain_se / std::fabs(own.gain));
  for (const auto& v : c.speed) {
    if (&v == best.v) continue;
    const Fit copy = LinearFit(chosen, grid.Of(v));
    if (!(copy.corr > 0.995)) continue;
    const Fit f = gain(v);
    if (f.n < 100 || std::fabs(f.corr) < std::fabs(best.fit.corr) - 0.02) continue;
    const double d = UnitDistance(f.gain);
    const bool better = d < dist - margin;
    evidence += fmt::format("{}{} follows {} (corr {:.4f}) at {:.3f} × its scale: a_y / (v r) lies {:.1f} % from a unit "
                            "combination with {}, {:.1f} % with {} (margin {:.1f} %) → {}",
                            evidence.empty() ? "" : "; ", v.expression, best.v->expression, copy.corr, copy.gain,
                            100 * (std::exp(dist) - 1), best.v->expression, 100 * (std::exp(d) - 1), v.expression,
                            100 * margin, better ? v.expression : best.v->expression);
    if (!better) continue;
    dist = d;
    best.v = &v;
    best.fit = LinearFit(SpeedTimesYaw(grid, v, *best.r, kKinematicSpeedFraction), grid.Of(*best.a));
  }
}

// What step 1 decides and the later steps read.
struct KinematicChoice {
  double sr = 1;                        // the sign that makes the yaw rate ISO 8855 (positive left)
  double fv = NAN, fr = NAN, fa = NAN;  // chosen unit factors to SI of speed, yaw rate, a_y
  std::vector<double> v_si;             // the speed on the grid [m/s]; empty: (v, r, a_y) not confirmed
};

// The posterior over the 12 unit combinations of (v, r, a_y): gain k = fv fr / fa.
struct UnitPosterior {
  size_t bv = 0, br = 0, ba = 0;          // the most probable combination
  double total = 0;                        // the posterior's normalisation (1 when implausible)
  double top = -1;                         // the best combination's weight
  std::vector<double> marg_v, marg_r, marg_a;  // marginals (unnormalised)
  bool plausible = false;                  // some combination is plausible (else confidence 0, CHECK)
};

UnitPosterior ChooseUnits(const Triple& best, double v99, double r99, double a99, double wheel_factor) {
  const auto& su = SpeedUnits();
  const auto& yu = YawUnits();
  const auto& au = AccelUnits();
  const auto pv = UnitPrior(su, best.v->unit), pr = UnitPrior(yu, best.r->unit), pa = UnitPrior(au, best.a->unit);
  const double k = std::fabs(best.fit.gain);
  const double sigma = std::hypot(0.1, best.fit.gain_se / k);
  UnitPosterior u;
  u.marg_v.assign(su.size(), 0.0);
  u.marg_r.assign(yu.size(), 0.0);
  u.marg_a.assign(au.size(), 0.0);
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
        u.total += w;
        u.marg_v[i] += w, u.marg_r[j] += w, u.marg_a[l] += w;
        if (w > u.top) u.top = w, u.bv = i, u.br = j, u.ba = l;
      }
  u.plausible = u.total > 0;
  if (!u.plausible) u.total = 1;
  return u;
}

// The absolute convention: the DBC's comments, else the usual bus convention. Sets k.sr and
// adds the note; returns the confidence in it.
double ChooseIsoSign(const Triple& best, int rel_a, KinematicChoice& k, InitResult& result) {
  int dir = CommentDirection(best.r->comment);
  std::string from = "the comment of " + best.r->expression;
  if (dir == 0 && (dir = CommentDirection(best.a->comment)) != 0) {
    dir *= rel_a;
    from = "the comment of " + best.a->expression;
  }
  if (dir != 0) {
    k.sr = dir;
    result.notes.push_back(fmt::format("ISO 8855 sign (yaw rate positive to the left) taken from {} (confidence 90 %)", from));
    return 0.9;
  }
  k.sr = 1;
  result.notes.push_back(
      "ISO 8855 sign ASSUMED: the bus's yaw rate is positive to the left (counter-clockwise seen from above, as on "
      "most buses); the DBC does not say and the data cannot tell left from right. Check once: in a left turn the "
      "yaw rate must come out positive, else flip the sign of yaw_rate, lateral_acceleration and "
      "steering_wheel_angle together (confidence 70 %)");
  return 0.7;
}

// 1. (v, r, a_y): a_y = k v r with the best correlated triple; their units, signs and evidence.
KinematicChoice ProposeKinematicRoles(const BusData& data, Grid& grid, const Triple& best, const std::vector<Source>& wheels,
                                      const std::string& copies, InitResult& result) {
  KinematicChoice k;
  const auto& su = SpeedUnits();
  const auto& yu = YawUnits();
  const auto& au = AccelUnits();
  const double v99 = Percentile(Abs(grid.Of(*best.v)), 0.99);
  const double r99 = Percentile(Abs(grid.Of(*best.r)), 0.99);
  const double a99 = Percentile(Abs(grid.Of(*best.a)), 0.99);
  const WheelChoice wheel = ChooseWheels(grid, wheels, *best.v, v99, best.r);
  const UnitPosterior u = ChooseUnits(best, v99, r99, a99, wheel.factor);
  const size_t bv = u.bv, br = u.br, ba = u.ba;
  const double total = u.total;
  k.fv = su[bv].to_si, k.fr = yu[br].to_si, k.fa = au[ba].to_si;
  const double p_combo = u.top / total;
  const double kc = k.fv * k.fr / k.fa;
  const int rel_a = best.fit.gain > 0 ? 1 : -1;
  const double p_abs = ChooseIsoSign(best, rel_a, k, result);
  const double p_rel = std::min(0.99, std::fabs(best.fit.corr));
  auto fill = [&](RoleProposal& p, const Source& s, const std::string& unit, double p_unit, int sign) {
    p.found = true;
    SetSource(p, s, data);
    p.unit = unit;
    p.sign = sign;
    p.confidence = std::min(p_unit, std::fabs(best.fit.corr));
    if (!u.plausible) p.evidence.push_back("no unit combination fits the gain within the plausible ranges");
  };
  // Speed forward positive: a bus that counts it negative (rare) gets sign -1.
  std::vector<double> moving_v;
  for (double x : grid.Of(*best.v))
    if (std::isfinite(x) && std::fabs(x) > 0.2 * v99) moving_v.push_back(x);
  const int v_sign = !moving_v.empty() && Percentile(moving_v, 0.5) < 0 ? -1 : 1;
  RoleProposal& speed = RoleOf(result, Role::kSpeed);
  RoleProposal& yaw = RoleOf(result, Role::kYawRate);
  RoleProposal& lat = RoleOf(result, Role::kLateralAcceleration);
  fill(speed, *best.v, su[bv].name, u.marg_v[bv] / total, v_sign);
  fill(yaw, *best.r, yu[br].name, u.marg_r[br] / total, static_cast<int>(k.sr));
  fill(lat, *best.a, au[ba].name, u.marg_a[ba] / total, static_cast<int>(k.sr) * rel_a);
  yaw.confidence = std::min(yaw.confidence, p_abs);
  lat.confidence = std::min({lat.confidence, p_abs, p_rel});
  const double gain = std::fabs(best.fit.gain);
  const std::string fit_text =
      fmt::format("a_y = k v r over {} samples at {:.0f} Hz: corr {:+.3f}, k = {:.5g} ± {:.2g} (bus units); "
                  "{} × {} / {} predicts {:.5g} (ratio {:.3f}); unit combination posterior {}",
                  best.fit.n, kGrid_hz, best.fit.corr, best.fit.gain, best.fit.gain_se, su[bv].name, yu[br].name,
                  au[ba].name, kc, gain / kc, Pct(p_combo));
  for (RoleProposal* p : {&speed, &yaw, &lat}) p->evidence.push_back(fit_text);
  lat.evidence.push_back(fmt::format("sign of k {} → a_y has {} sign as the yaw rate", rel_a > 0 ? "+" : "−",
                                     rel_a > 0 ? "the same" : "the opposite"));
  speed.evidence.push_back(fmt::format("unit {} (posterior {}; DBC says '{}'); p99 = {:.1f} m/s", su[bv].name,
                                       Pct(u.marg_v[bv] / total), best.v->unit, v99 * k.fv));
  yaw.evidence.push_back(fmt::format("unit {} (posterior {}; DBC says '{}'); p99 |r| = {:.3f} rad/s", yu[br].name,
                                     Pct(u.marg_r[br] / total), best.r->unit, r99 * k.fr));
  lat.evidence.push_back(fmt::format("unit {} (posterior {}; DBC says '{}'); p99 |a_y| = {:.2f} m/s^2", au[ba].name,
                                     Pct(u.marg_a[ba] / total), best.a->unit, a99 * k.fa));
  if (!copies.empty()) speed.evidence.push_back(copies);
  if (!wheel.text.empty()) speed.evidence.push_back(wheel.text);
  if (!best.r->pair_evidence.empty()) RoleOf(result, Role::kYawRate).evidence.push_back(best.r->pair_evidence);
  if (!best.a->pair_evidence.empty()) RoleOf(result, Role::kLateralAcceleration).evidence.push_back(best.a->pair_evidence);
  k.v_si = grid.Of(*best.v);
  for (double& x : k.v_si) x *= k.fv * v_sign;
  return k;
}

// The bus: the one all found roles are on, if the log has several ("" otherwise).
std::string CommonBus(const BusData& data, const InitResult& result) {
  std::string bus;
  bool one = true;
  for (const auto& p : result.roles) {
    if (!p.found) continue;
    const std::string& b = data.BusOf(p.message);
    if (bus.empty()) bus = b;
    else if (b != bus) one = false;
  }
  return one && data.bus_names.size() > 1 ? bus : "";
}

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
  const RoleCandidates c = FindCandidates(data, result);

  // 1. (v, r, a_y): a_y = k v r. The best correlated triple among the named candidates.
  Triple best = BestKinematicTriple(grid, c);
  std::string copies;
  PreferUnscaledSpeed(grid, c, best, copies);
  KinematicChoice k;
  if (best.v != nullptr && std::fabs(best.fit.corr) >= 0.5) {
    k = ProposeKinematicRoles(data, grid, best, c.wheels, copies, result);
  } else {
    const std::string why = best.v == nullptr
                                ? "no (speed, yaw rate, a_y) candidates to test a_y = v r with"
                                : fmt::format("the best candidates ({}, {}, {}) do not follow a_y = v r (corr {:+.2f} < 0.5)",
                                              best.v->expression, best.r->expression, best.a->expression, best.fit.corr);
    for (Role rl : {Role::kSpeed, Role::kYawRate, Role::kLateralAcceleration})
      if (RoleOf(result, rl).reason.empty()) RoleOf(result, rl).reason = why;
  }

  // 1b. No yaw rate confirmed: a_y = v^2 d_sw / (is l (1 + v^2/v_ch^2)) instead.
  const bool yaw_found = !k.v_si.empty();
  if (!yaw_found && !c.speed.empty() && !c.lat.empty() && !c.steer.empty()) {
    k.v_si = ProposeWithoutYawRate(data, grid, c.speed, c.lat, c.steer, options, result);
    if (!k.v_si.empty())
      for (Role rl : {Role::kSpeed, Role::kLateralAcceleration}) RoleOf(result, rl).reason.clear();
  }
  size_t moving = 0;
  for (double x : k.v_si) moving += std::isfinite(x) && x > kMoving_mps;
  result.moving_s = static_cast<double>(moving) / kGrid_hz;

  // 2. Steering: kappa (1 + v^2/v_ch^2) = g d_sw with kappa = r / v, over every moving sample.
  if (yaw_found && !c.steer.empty()) {
    ProposeSteering(data, grid, *best.r, k.fr * k.sr, k.v_si, c.steer, options, result);
  } else if (!RoleOf(result, Role::kSteeringWheelAngle).found && RoleOf(result, Role::kSteeringWheelAngle).reason.empty()) {
    RoleOf(result, Role::kSteeringWheelAngle).reason = "needs the speed and yaw rate (r = v d_sw / (is l)) or a_y (a_y = v^2 d_sw / (is l)) confirmed first";
  }

  // 3. a_x = dv/dt.
  ProposeLongitudinal(data, grid, k.v_si, c.lon, result);

  // 4. Conditioning: a_y and the yaw rate low-passed where they are noisier than the dynamics.
  ProposeConditioning(data, c.lat, c.yaw, k.v_si, result);

  // 5. The wheel speeds that follow the chosen speed, their scale from it (may reallocate result.roles).
  if (!k.v_si.empty()) {
    for (const auto& v : c.speed) {
      if (v.expression != RoleOf(result, Role::kSpeed).expression) continue;
      ProposeWheelSpeed(data, grid, ChooseWheels(grid, c.wheels, v, Percentile(Abs(grid.Of(v)), 0.99), yaw_found ? best.r : nullptr),
                        k.v_si, result);
      break;
    }
  }

  const std::string bus = CommonBus(data, result);
  if (!bus.empty()) result.bus = bus;
  return result;
}

}  // namespace ndsid::desk
