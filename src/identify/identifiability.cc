// FitStatistics::Identifiability: the identifiability report of a fit (fit_statistics.h).
#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <cstdio>
#include <sstream>
#include <string>

#include "fit_statistics.h"

namespace ndsid::identify {
namespace {

// A direction over the free parameters as "+0.50 m +0.50 Jz ..." (entries below 0.1 left out).
std::string DescribeDirection(const Eigen::VectorXd& v, const std::vector<int>& free, const model::ModelSpec& spec) {
  std::ostringstream os;
  os.precision(2);
  os << std::fixed;
  for (int k = 0; k < v.size(); ++k) {
    if (std::abs(v[k]) < 0.1) continue;
    os << (v[k] >= 0 ? " +" : " ") << v[k] << ' ' << spec.param_name(free[k]);
  }
  return os.str();
}

}  // namespace

void FitStatistics::Identifiability(bool two_outputs, size_t chunks_with_yaw, size_t chunks) {
  const std::vector<int>& free = box_.free;
  const int nf = nf_;
  IdentificationResult& r = r_;
  const Eigen::MatrixXd& jtj_f = jtj_f_;
  Eigen::VectorXd d(nf);
  for (int a = 0; a < nf; ++a) d[a] = jtj_f(a, a) > 0 ? 1.0 / std::sqrt(jtj_f(a, a)) : 0.0;
  const Eigen::MatrixXd scaled = d.asDiagonal() * jtj_f * d.asDiagonal();
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(scaled);
  const Eigen::VectorXd ev = es.eigenvalues().cwiseMax(0.0);  // ascending
  const double smax = std::sqrt(ev[nf - 1]);
  IdentifiabilityReport& rep = r.identifiability;
  rep.singular_values.fill(0.0);
  for (int a = 0; a < std::min<int>(nf, model::kNumParams); ++a) rep.singular_values[a] = std::sqrt(ev[nf - 1 - a]);
  rep.condition_number = std::sqrt(ev[0]) > 0 ? smax / std::sqrt(ev[0]) : INFINITY;
  for (int a = 0; a < nf; ++a) {
    const double ratio = smax > 0 ? std::sqrt(ev[a]) / smax : 0.0;
    if (ratio < 1e-3) {
      rep.weak.push_back({ratio, "not determined by the data:" + DescribeDirection(es.eigenvectors().col(a), free, settings_.spec)});
    }
  }
  if (settings_.config.params[model::kMass].fixed) {
    rep.notes.push_back("m fixed at " + std::to_string(static_cast<int>(r.params[0].value)) +
                        " kg from configuration: (d_sw, v, a_y) determine only cv/m, ch/m, Jz/m, lv, is; EG depends on m/cv, m/ch only");
  } else {
    rep.notes.push_back("m free: scaling m, Jz, cv, ch together leaves a_y unchanged, so m is not determined (expect it in the weak directions); EG is still determined");
  }
  for (int a = 0; a < nf; ++a) {
    const ParameterEstimate& pe = EstimateOfFree(a);
    if (pe.value != 0 && pe.se / std::abs(pe.value) > 0.1) {
      rep.notes.push_back(pe.name + " weakly determined (relative standard error " +
                          std::to_string(static_cast<int>(100 * pe.se / std::abs(pe.value))) + " %)");
    }
    if (pe.at_bound) rep.notes.push_back(pe.name + " ended on its bound");
  }
  if (two_outputs) {
    char note[320];
    std::snprintf(note, sizeof note,
                  "outputs: a_y and yaw rate (%zu of %zu chunks have a yaw rate), each weighted by 1/sqrt(sigma^2 tau): "
                  "a_y %.3g (m/s^2)^2, yaw rate %.3g (deg/s)^2 per sample",
                  chunks_with_yaw, chunks, r.noise_level_a_y, r.noise_level_yaw_rate * (180 / M_PI) * (180 / M_PI));
    rep.notes.push_back(note);
  } else if (settings_.config.yaw_rate_output) {
    rep.notes.push_back("outputs: a_y alone (identification.outputs asks for the yaw rate, but no chunk has one)");
  }
  for (const std::string& n : priors_.Notes()) rep.notes.push_back(n);
}

}  // namespace ndsid::identify
