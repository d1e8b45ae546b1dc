#include "ndsid/adequacy/prior_check.h"

#include <cmath>
#include <cstdio>

namespace ndsid::adequacy {
double Chi2Quantile999(size_t dof) {
  static const double kTable[] = {10.83, 13.82, 16.27, 18.47, 20.52, 22.46, 24.32, 26.12, 27.88, 29.59};
  if (dof >= 1 && dof <= 10) return kTable[dof - 1];
  const double k = static_cast<double>(dof), z = 3.090;  // the normal 0.999 quantile
  const double c = 2.0 / (9.0 * k);
  return k * std::pow(1.0 - c + z * std::sqrt(c), 3);
}

PriorDistance DistanceFromPriors(const std::vector<FittedParameter>& fit, const std::vector<config::ParameterPrior>& priors) {
  PriorDistance d;
  double sum = 0;
  for (const config::ParameterPrior& pr : priors) {
    for (const FittedParameter& p : fit) {
      if (p.name != pr.name || p.fixed || !(pr.sd > 0)) continue;
      const double z = (p.value - pr.value) / pr.sd;
      d.z.emplace_back(p.name, z);
      sum += z * z;
    }
  }
  if (d.z.empty()) return d;
  d.distance = std::sqrt(sum);
  d.threshold = std::sqrt(Chi2Quantile999(d.z.size()));
  d.contradicts = d.distance > d.threshold;
  return d;
}

std::string PriorDistance::Note() const {
  char buf[64];
  std::snprintf(buf, sizeof buf, "posterior %.1f prior sds from model.priors (", distance);
  std::string s = buf;
  for (size_t i = 0; i < z.size(); ++i) {
    std::snprintf(buf, sizeof buf, "%s%s %+.1f", i ? ", " : "", z[i].first.c_str(), z[i].second);
    s += buf;
  }
  if (!contradicts) return s + ")";
  std::snprintf(buf, sizeof buf, "): contradicts them (above %.1f); refit without them", threshold);
  return s + buf;
}

}  // namespace ndsid::adequacy
