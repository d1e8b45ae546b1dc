#include "ndsid/identify/identifier.h"

#include <ceres/ceres.h>
#include <spdlog/spdlog.h>

#include <Eigen/Dense>
#include <chrono>
#include <cstdio>
#include <cmath>
#include <memory>
#include <sstream>

#include "chunks.h"

namespace ndsid::identify {
namespace {

using Vec6 = Eigen::Matrix<double, 6, 1>;
using Mat6 = Eigen::Matrix<double, 6, 6>;
using CostFn = ceres::DynamicAutoDiffCostFunction<ChunkResidual, 6>;

std::unique_ptr<CostFn> MakeCost(const Chunk& c, size_t burn, double l, const std::array<double, 6>& scale) {
  auto* functor = new ChunkResidual(c, burn, l, scale);
  auto cost = std::make_unique<CostFn>(functor);
  cost->AddParameterBlock(6);
  cost->SetNumResiduals(static_cast<int>(functor->num_residuals()));
  return cost;
}

// Integrated autocorrelation time of the residuals (1 + 2 sum of the autocorrelation up to the
// first lag where it turns negative), averaged over chunks: the factor by which strongly
// correlated 50 Hz residuals overstate the information in the data.
double IntegratedAutocorrelationTime(const std::vector<std::vector<double>>& residuals_by_chunk) {
  constexpr size_t kMaxLag = 200;
  std::vector<double> acf(kMaxLag + 1, 0.0);
  double var = 0;
  for (const auto& e : residuals_by_chunk) {
    const size_t n = e.size();
    for (size_t lag = 0; lag <= std::min(kMaxLag, n ? n - 1 : 0); ++lag) {
      double s = 0;
      for (size_t k = lag; k < n; ++k) s += e[k] * e[k - lag];
      acf[lag] += s;
    }
  }
  var = acf[0];
  if (var <= 0) return 1.0;
  double tau = 1.0;
  for (size_t lag = 1; lag <= kMaxLag; ++lag) {
    const double rho = acf[lag] / var;
    if (rho <= 0) break;
    tau += 2.0 * rho;
  }
  return tau;
}

std::string DescribeDirection(const Eigen::VectorXd& v, const std::vector<int>& free) {
  std::ostringstream os;
  os.precision(2);
  os << std::fixed;
  for (int k = 0; k < v.size(); ++k) {
    if (std::abs(v[k]) < 0.1) continue;
    os << (v[k] >= 0 ? " +" : " ") << v[k] << ' ' << model::kParamNames[free[k]];
  }
  return os.str();
}

}  // namespace

model::Params<double> IdentificationResult::AsParams() const {
  double p[6];
  for (int i = 0; i < 6; ++i) p[i] = params[i].value;
  return model::Params<double>::FromArray(p);
}

Identifier::Identifier(const config::IdentificationConfig& config, double wheelbase_m)
    : config_(config), wheelbase_m_(wheelbase_m) {}

model::Params<double> Identifier::WarmStart(double steer_ratio, double eg) const {
  double p[6];
  for (int i = 0; i < 6; ++i) p[i] = config_.params[i].initial;
  auto clamp = [&](int i, double v) { return std::clamp(v, config_.params[i].lower, config_.params[i].upper); };
  if (std::isfinite(steer_ratio) && steer_ratio > 0) p[model::kSteerRatio] = clamp(model::kSteerRatio, steer_ratio);
  if (std::isfinite(eg)) {
    // EG = m/l (lh/cv - lv/ch)  =>  cv = lh / (EG l/m + lv/ch)
    const double l = wheelbase_m_, m = p[model::kMass], lv = p[model::kCgToFront], lh = l - lv;
    const double denom = eg * l / m + lv / p[model::kStiffRear];
    if (denom > 0) p[model::kStiffFront] = clamp(model::kStiffFront, lh / denom);
  }
  return model::Params<double>::FromArray(p);
}

double Identifier::Rmse(const model::Params<double>& p, const SegmentList& segments, size_t* count) const {
  const auto chunks = MakeChunks(segments, config_.chunk_s, config_.burn_in_s);
  double sum = 0;
  size_t n = 0;
  std::vector<double> a_y;
  for (const Chunk& c : chunks) {
    a_y.resize(c.n);
    const stats::SegmentSample* s = c.samples;
    model::SimulateLateralAcceleration(
        p, wheelbase_m_, c.dt_s, c.n, [s](size_t k) { return static_cast<double>(s[k].steer_rad); },
        [s](size_t k) { return static_cast<double>(s[k].speed_mps); }, a_y.data());
    for (size_t k = BurnInSamples(c, config_.burn_in_s); k < c.n; ++k) {
      const double e = s[k].lat_accel_mps2 - a_y[k];
      sum += e * e;
      ++n;
    }
  }
  if (count) *count = n;
  return n ? std::sqrt(sum / static_cast<double>(n)) : -1.0;
}

IdentificationResult Identifier::Identify(const SegmentList& training, const SegmentList& validation,
                                          const std::optional<model::Params<double>>& warm_start) const {
  IdentificationResult r;
  const auto t_start = std::chrono::steady_clock::now();
  const auto chunks = MakeChunks(training, config_.chunk_s, config_.burn_in_s);
  if (chunks.empty()) {
    r.reason = "no gated segment long enough for the dynamic fit";
    return r;
  }
  double p0[6];
  if (warm_start) {
    const double w[6] = {warm_start->m, warm_start->Jz, warm_start->cv, warm_start->ch, warm_start->lv, warm_start->is};
    for (int i = 0; i < 6; ++i) p0[i] = std::clamp(w[i], config_.params[i].lower, config_.params[i].upper);
  } else {
    for (int i = 0; i < 6; ++i) p0[i] = config_.params[i].initial;
  }
  if (config_.params[model::kMass].fixed) p0[model::kMass] = config_.params[model::kMass].initial;
  std::array<double, 6> scale{};
  for (int i = 0; i < 6; ++i) scale[i] = config_.params[i].initial;
  double theta[6];
  for (int i = 0; i < 6; ++i) theta[i] = p0[i] / scale[i];

  ceres::Problem::Options problem_options;
  problem_options.cost_function_ownership = ceres::DO_NOT_TAKE_OWNERSHIP;
  ceres::Problem problem(problem_options);
  std::vector<std::unique_ptr<CostFn>> costs;
  costs.reserve(chunks.size());
  size_t n_res = 0;
  for (const Chunk& c : chunks) {
    costs.push_back(MakeCost(c, BurnInSamples(c, config_.burn_in_s), wheelbase_m_, scale));
    problem.AddResidualBlock(costs.back().get(), nullptr, theta);
    n_res += static_cast<size_t>(costs.back()->num_residuals());
  }
  std::vector<int> fixed, free;
  for (int i = 0; i < 6; ++i) {
    (config_.params[i].fixed ? fixed : free).push_back(i);
    problem.SetParameterLowerBound(theta, i, config_.params[i].lower / scale[i]);
    problem.SetParameterUpperBound(theta, i, config_.params[i].upper / scale[i]);
  }
  if (free.empty()) {
    r.reason = "every parameter is fixed";
    return r;
  }
  if (!fixed.empty()) problem.SetManifold(theta, new ceres::SubsetManifold(6, fixed));

  ceres::Solver::Options options;
  options.linear_solver_type = ceres::DENSE_NORMAL_CHOLESKY;
  options.max_num_iterations = config_.max_iterations;
  options.num_threads = config_.threads;
  options.function_tolerance = 1e-10;
  options.parameter_tolerance = 1e-10;
  options.gradient_tolerance = 1e-12;
  options.logging_type = ceres::SILENT;
  ceres::Solver::Summary summary;
  ceres::Solve(options, &problem, &summary);
  r.iterations = static_cast<int>(summary.iterations.size());
  r.termination = ceres::TerminationTypeToString(summary.termination_type);
  if (!summary.IsSolutionUsable()) {
    r.reason = "solver failed: " + summary.message;
    return r;
  }

  // Residuals and Jacobian at the optimum, accumulated per chunk: J'J, the per-chunk scores
  // (cluster-robust covariance) and the residual series (autocorrelation time).
  Mat6 jtj = Mat6::Zero();
  std::vector<Vec6> chunk_scores;
  std::vector<std::vector<double>> chunk_residuals;
  double rss = 0;
  const double* params[] = {theta};
  for (const auto& cost : costs) {
    const int m = cost->num_residuals();
    std::vector<double> e(static_cast<size_t>(m));
    std::vector<double> jac(static_cast<size_t>(m) * 6);
    double* jacs[] = {jac.data()};
    cost->Evaluate(params, e.data(), jacs);
    Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, 6, Eigen::RowMajor>> J(jac.data(), m, 6);
    Eigen::Map<const Eigen::VectorXd> ev(e.data(), m);
    // Jacobian of the *model output* is -J; signs cancel in J'J and in the score's outer product.
    jtj += J.transpose() * J;
    chunk_scores.push_back(J.transpose() * ev);
    rss += ev.squaredNorm();
    chunk_residuals.push_back(std::move(e));
  }
  r.residuals_train = n_res;
  r.chunks = chunks.size();
  for (const Chunk& c : chunks) r.train_hours += c.n * c.dt_s / 3600.0;
  r.rmse_train_mps2 = std::sqrt(rss / static_cast<double>(n_res));
  if (!std::isfinite(r.rmse_train_mps2)) {
    r.reason = "non-finite residuals at the solution";
    return r;
  }

  // Covariance of the free parameters in theta space.
  const int nf = static_cast<int>(free.size());
  Eigen::MatrixXd jtj_f(nf, nf);
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) jtj_f(a, b) = jtj(free[a], free[b]);
  const Eigen::MatrixXd jtj_inv = jtj_f.completeOrthogonalDecomposition().pseudoInverse();
  const double sigma2 = rss / std::max<double>(1.0, static_cast<double>(n_res) - nf);
  // Gradient of EG with respect to theta (free parameters), by forward-mode autodiff.
  using Jet = ceres::Jet<double, 6>;
  model::Params<Jet> pj{Jet(theta[0] * scale[0], 0), Jet(theta[1] * scale[1], 1), Jet(theta[2] * scale[2], 2),
                        Jet(theta[3] * scale[3], 3), Jet(theta[4] * scale[4], 4), Jet(theta[5] * scale[5], 5)};
  const Jet eg = model::SelfSteerGradient(pj, wheelbase_m_);
  Eigen::VectorXd eg_grad(nf);
  for (int a = 0; a < nf; ++a) eg_grad[a] = eg.v[free[a]] * scale[free[a]];

  // Two honest covariances for autocorrelated residuals; the one more cautious about EG wins:
  // the classical one inflated by the residuals' integrated autocorrelation time, and (with
  // enough chunks) the cluster-robust sandwich over chunks.
  const double tau = IntegratedAutocorrelationTime(chunk_residuals);
  Eigen::MatrixXd cov = jtj_inv * sigma2 * tau;
  char method[160];
  std::snprintf(method, sizeof method, "autocorrelation-corrected (tau=%.1f)", tau);
  r.se_method = method;
  const size_t g = chunk_scores.size();
  if (g >= 10) {
    Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(nf, nf);
    for (const Vec6& sc : chunk_scores) {
      Eigen::VectorXd sf(nf);
      for (int a = 0; a < nf; ++a) sf[a] = sc[free[a]];
      meat += sf * sf.transpose();
    }
    const Eigen::MatrixXd cov_cluster = jtj_inv * meat * jtj_inv * (static_cast<double>(g) / (g - 1.0));
    if (eg_grad.dot(cov_cluster * eg_grad) > eg_grad.dot(cov * eg_grad)) {
      cov = cov_cluster;
      r.se_method = "cluster-robust over " + std::to_string(g) + " chunks";
    }
  }

  // Parameters, standard errors, correlations.
  for (int i = 0; i < 6; ++i) {
    ParameterEstimate& pe = r.params[i];
    pe.value = theta[i] * scale[i];
    pe.fixed = config_.params[i].fixed;
    const double lo = config_.params[i].lower, hi = config_.params[i].upper;
    pe.at_bound = !pe.fixed && (pe.value <= lo + 1e-6 * (hi - lo) || pe.value >= hi - 1e-6 * (hi - lo));
  }
  for (int a = 0; a < nf; ++a) r.params[free[a]].se = std::sqrt(std::max(0.0, cov(a, a))) * scale[free[a]];
  r.correlation.fill(0.0);
  for (int i = 0; i < 6; ++i) r.correlation[i * 6 + i] = 1.0;
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) {
      const double d = std::sqrt(cov(a, a) * cov(b, b));
      r.correlation[free[a] * 6 + free[b]] = d > 0 ? cov(a, b) / d : 0.0;
    }

  // EG and its standard error by the delta method.
  r.eg_rad_per_mps2 = eg.a;
  r.eg_se_rad_per_mps2 = std::sqrt(std::max(0.0, eg_grad.dot(cov * eg_grad)));
  r.eg_deg_per_g = model::EgToDegPerG(r.eg_rad_per_mps2);
  r.eg_se_deg_per_g = model::EgToDegPerG(r.eg_se_rad_per_mps2);

  // Identifiability: singular values of the column-scaled Jacobian over the free parameters.
  {
    Eigen::VectorXd d(nf);
    for (int a = 0; a < nf; ++a) d[a] = jtj_f(a, a) > 0 ? 1.0 / std::sqrt(jtj_f(a, a)) : 0.0;
    const Eigen::MatrixXd scaled = d.asDiagonal() * jtj_f * d.asDiagonal();
    Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(scaled);
    const Eigen::VectorXd ev = es.eigenvalues().cwiseMax(0.0);  // ascending
    const double smax = std::sqrt(ev[nf - 1]);
    IdentifiabilityReport& rep = r.identifiability;
    rep.singular_values.fill(0.0);
    for (int a = 0; a < nf; ++a) rep.singular_values[a] = std::sqrt(ev[nf - 1 - a]);
    rep.condition_number = std::sqrt(ev[0]) > 0 ? smax / std::sqrt(ev[0]) : INFINITY;
    for (int a = 0; a < nf; ++a) {
      const double ratio = smax > 0 ? std::sqrt(ev[a]) / smax : 0.0;
      if (ratio < 1e-3) {
        rep.weak.push_back({ratio, "not determined by the data:" + DescribeDirection(es.eigenvectors().col(a), free)});
      }
    }
    if (config_.params[model::kMass].fixed) {
      rep.notes.push_back("m fixed at " + std::to_string(static_cast<int>(r.params[0].value)) +
                          " kg from configuration: (d_sw, v, a_y) determine only cv/m, ch/m, Jz/m, lv, is; EG depends on m/cv, m/ch only");
    } else {
      rep.notes.push_back("m free: scaling m, Jz, cv, ch together leaves a_y unchanged, so m is not determined (expect it in the weak directions); EG is still determined");
    }
    for (int a = 0; a < nf; ++a) {
      const ParameterEstimate& pe = r.params[free[a]];
      if (pe.value != 0 && pe.se / std::abs(pe.value) > 0.1) {
        rep.notes.push_back(std::string(model::kParamNames[free[a]]) + " weakly determined (relative standard error " +
                            std::to_string(static_cast<int>(100 * pe.se / std::abs(pe.value))) + " %)");
      }
      if (pe.at_bound) rep.notes.push_back(std::string(model::kParamNames[free[a]]) + " ended on its bound");
    }
  }

  if (!validation.empty()) {
    r.rmse_validation_mps2 = Rmse(r.AsParams(), validation, &r.residuals_validation);
  }
  r.solve_seconds = std::chrono::duration<double>(std::chrono::steady_clock::now() - t_start).count();
  r.valid = std::isfinite(r.eg_rad_per_mps2) && std::isfinite(r.eg_se_rad_per_mps2);
  if (!r.valid) r.reason = "non-finite EG or standard error";
  return r;
}

}  // namespace ndsid::identify
