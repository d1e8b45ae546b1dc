#include "evidence_priors.h"

#include <cmath>
#include <set>
#include <vector>

#include "ndsid/identify/identifier.h"
#include "ndsid/model/effect_library.h"

namespace ndsid::identify {

bool HasConfiguredPrior(const config::IdentificationConfig& config, const std::string& name) {
  return std::any_of(config.priors.begin(), config.priors.end(), [&](const config::ParameterPrior& pr) { return pr.name == name; });
}

std::vector<Identifier::StandstillPrior> Identifier::StandstillPriors(const std::vector<gate::StandstillStop>& stops,
                                                                      const std::set<int64_t>& drives) {
  // Each stop is one observation (its mean over often hundreds of correlated samples): the
  // spread between stops holds the sensor noise, the cross-slope where the car stood and any
  // drift of the offset, so the standard error of the mean over the stops is honest without a
  // noise model. Floor: 1 % of the effect's typical magnitude (identical stops, e.g. a coarsely
  // quantised sensor, would otherwise make an infinitely sure prior).
  std::vector<StandstillPrior> out;
  auto add = [&](const char* effect, auto value_of) {
    const auto e = model::EffectLibrary::Builtin().Find(effect);
    if (!e || e->info().params.empty()) return;
    const std::string& param = e->info().params[0].name;
    const double typical = e->info().params[0].typical;
    std::vector<double> v;
    double seconds = 0;
    for (const gate::StandstillStop& st : stops) {
      if (!drives.empty() && !drives.count(st.drive_id)) continue;
      const double x = value_of(st);
      if (!std::isfinite(x)) continue;
      v.push_back(x);
      seconds += st.seconds;
    }
    if (v.size() < kMinStops) return;
    const double n = static_cast<double>(v.size());
    double mean = 0, ss = 0;
    for (double x : v) mean += x / n;
    for (double x : v) ss += (x - mean) * (x - mean);
    const double se = std::sqrt(ss / (n - 1) / n);
    out.push_back({param, mean, std::max(se, 0.01 * typical), v.size(), seconds});
  };
  add("gyro_offset", [](const gate::StandstillStop& st) { return st.mean_yaw_rate_radps; });
  add("accel_bias", [](const gate::StandstillStop& st) { return st.mean_lat_accel_mps2; });
  return out;
}

}  // namespace ndsid::identify
