// `ndsid init`'s conditioning (vehicle_init_detail.h): a lateral acceleration or yaw rate whose
// raw samples scatter far more about their 0.5 s moving mean than the vehicle's dynamics do (a
// raw IMU on a vibrating mount) gets signals.<role>.lowpass_hz (docs/configuration.md,
// "Conditioning"), with the measured noise in its evidence.
#include <spdlog/fmt/fmt.h>

#include <cmath>

#include "vehicle_init_detail.h"

namespace ndsid::desk::init_detail {

using config::Role;

namespace {

constexpr double kNoiseWindow_s = 0.5;       // the moving mean the noise is measured about
constexpr double kNoiseMoving_mps = 3.0;     // measured while the vehicle moves
constexpr double kLatNoiseMax_mps2 = 0.5;    // a_y: above this the dynamics no longer dominate
constexpr double kTypicalSpeed_mps = 15.0;   // the yaw rate's limit is a_y's at this speed (a_y = v r)
constexpr double kYawNoiseMax_radps = kLatNoiseMax_mps2 / kTypicalSpeed_mps;
constexpr double kLowpass_hz = 5.0;          // above what the driver steers, below the vibration

// The source's raw values (terms of one message combined sample by sample).
std::vector<double> RawValues(const BusData& data, const Source& s) {
  const SignalSeries& first = data.signals[static_cast<size_t>(s.terms[0])];
  std::vector<double> x = first.v;
  if (s.terms.size() < 2) return x;
  const SignalSeries& b = data.signals[static_cast<size_t>(s.terms[1])];
  if (b.v.size() != x.size()) return x;
  for (size_t i = 0; i < x.size(); ++i) {
    switch (s.combine) {
      case Source::Combine::kSum: x[i] += b.v[i]; break;
      case Source::Combine::kDifference: x[i] -= b.v[i]; break;
      case Source::Combine::kSignMagnitude: x[i] *= 1.0 - 2.0 * b.v[i]; break;
      case Source::Combine::kSingle: break;
    }
  }
  return x;
}

// Fills the role's lowpass_hz and evidence from its measured noise.
void Condition(const BusData& data, const Source& s, double to_si, double limit, const char* unit, double unit_scale,
               const std::vector<double>& v_si, RoleProposal& p) {
  const double noise = HighFrequencyNoise(data, s, to_si, v_si);
  if (!std::isfinite(noise)) return;
  const std::string measured = fmt::format("noise: std {:.3g} {} about its {:.1f} s moving mean while moving", noise * unit_scale,
                                           unit, kNoiseWindow_s);
  if (noise > limit) {
    p.lowpass_hz = kLowpass_hz;
    p.evidence.push_back(fmt::format("{} (above {:.3g} {}: more than the dynamics) → lowpass_hz {:g} (docs/configuration.md, "
                                     "Conditioning)",
                                     measured, limit * unit_scale, unit, kLowpass_hz));
  } else {
    p.evidence.push_back(fmt::format("{} (at most {:.3g} {}: no conditioning)", measured, limit * unit_scale, unit));
  }
}

}  // namespace

double HighFrequencyNoise(const BusData& data, const Source& s, double to_si, const std::vector<double>& v_si) {
  const SignalSeries& first = data.signals[static_cast<size_t>(s.terms[0])];
  const std::vector<double> x = RawValues(data, s);
  const std::vector<double>& t = first.t;
  const double h = 0.5 * kNoiseWindow_s;
  double sum = 0, sq = 0;
  size_t n = 0, lo = 0, hi = 0;
  double window = 0;  // the sum of x over [lo, hi)
  for (size_t i = 0; i < x.size(); ++i) {
    while (hi < x.size() && t[hi] <= t[i] + h) window += x[hi++];
    while (lo < i && t[lo] < t[i] - h) window -= x[lo++];
    const size_t g = static_cast<size_t>(std::lround((t[i] - data.t0) * kGrid_hz));
    if (g >= v_si.size() || !(v_si[g] > kNoiseMoving_mps) || hi - lo < 3) continue;
    const double d = (x[i] - window / static_cast<double>(hi - lo)) * to_si;
    sum += d, sq += d * d, ++n;
  }
  if (n < 200) return NAN;
  const double mean = sum / static_cast<double>(n);
  return std::sqrt(std::max(0.0, sq / static_cast<double>(n) - mean * mean));
}

void ProposeConditioning(const BusData& data, const std::vector<Source>& lat, const std::vector<Source>& yaw,
                         const std::vector<double>& v_si, InitResult& result) {
  if (v_si.empty()) return;
  for (const auto& [role, sources] : {std::pair{Role::kLateralAcceleration, &lat}, std::pair{Role::kYawRate, &yaw}}) {
    RoleProposal& p = RoleOf(result, role);
    if (!p.found) continue;
    for (const auto& s : *sources) {
      if (s.expression != p.expression) continue;
      const double to_si = config::UnitToSi(role, p.unit);
      if (role == Role::kLateralAcceleration) Condition(data, s, to_si, kLatNoiseMax_mps2, "m/s^2", 1.0, v_si, p);
      else Condition(data, s, to_si, kYawNoiseMax_radps, "deg/s", 180.0 / M_PI, v_si, p);
      break;
    }
  }
}

}  // namespace ndsid::desk::init_detail
