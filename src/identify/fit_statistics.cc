#include "fit_statistics.h"

#include <ceres/jet.h>
#include <spdlog/spdlog.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <string>

#include "half_estimates.h"
#include "ndsid/model/single_track.h"
#include "residual_sums.h"

namespace ndsid::identify {

FitStatistics::FitStatistics(const FitSettings& settings, const ParameterBox& box, const std::vector<double>& theta,
                             const EvidencePriors& priors, const OptimumSums& sums, IdentificationResult& result)
    : settings_(settings),
      box_(box),
      theta_(theta),
      priors_(priors),
      sums_(sums),
      r_(result),
      np_(box.size()),
      nf_(static_cast<int>(box.free.size())) {}

ParameterEstimate& FitStatistics::EstimateOfFree(int a) {
  const int i = box_.free[a];
  return i < model::kNumParams ? r_.params[i] : r_.effect_params[i - model::kNumParams];
}

void FitStatistics::Covariance(bool incremental) {
  const std::vector<int>& free = box_.free;
  const std::vector<double>& theta = theta_;
  const std::vector<double>& scale = box_.scale;
  const int nf = nf_;
  jtj_f_.resize(nf, nf);
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) jtj_f_(a, b) = sums_.jtj(free[a], free[b]);
  sigma2_ = sums_.rss / std::max<double>(1.0, static_cast<double>(sums_.n_res) - nf);
  // Prior information in theta space (zero without priors).
  const Eigen::MatrixXd prior_info = priors_.InformationTheta(theta.data(), free);

  // Gradient of EG with respect to theta (free base parameters), by forward-mode autodiff.
  using Jet6 = ceres::Jet<double, 6>;
  model::Params<Jet6> pj{Jet6(theta[0] * scale[0], 0), Jet6(theta[1] * scale[1], 1), Jet6(theta[2] * scale[2], 2),
                         Jet6(theta[3] * scale[3], 3), Jet6(theta[4] * scale[4], 4), Jet6(theta[5] * scale[5], 5)};
  const Jet6 eg = model::SelfSteerGradient(pj, settings_.wheelbase_m);
  eg_rad_per_mps2_ = eg.a;
  eg_grad_ = Eigen::VectorXd::Zero(nf);
  for (int a = 0; a < nf; ++a) {
    if (free[a] < model::kNumParams) eg_grad_[a] = eg.v[free[a]] * scale[free[a]];
  }

  if (incremental) {
    std::vector<double> acf = sums_.acf_a;
    AddSums(sums_.acf_r, acf);
    tau_ = AutocorrelationTimeFromSums(acf);
  } else {
    tau_ = IntegratedAutocorrelationTime(sums_.chunk_residuals, settings_.config.threads);
  }
  // Classical: (J'J / (sigma^2 tau) + P)^-1; sandwich bread: (J'J + sigma^2 tau P)^-1.
  const Eigen::MatrixXd jtj_inv = (jtj_f_ + sigma2_ * tau_ * prior_info).completeOrthogonalDecomposition().pseudoInverse();
  cov_ = jtj_inv * sigma2_ * tau_;
  const Eigen::MatrixXd configured_info = priors_.InformationTheta(theta.data(), free, true);
  if (configured_info.squaredNorm() > 0) {
    // EG's variance without model.priors (the data and the vehicle's own evidence), over that
    // with them (both classical): model.priors' share of EG's information. A direction the rest
    // leaves undetermined drops out of the pseudo-inverse, which can only lower the share.
    const Eigen::MatrixXd own = jtj_f_ + sigma2_ * tau_ * (prior_info - configured_info);
    const double with = eg_grad_.dot(jtj_inv * eg_grad_);
    const double alone = eg_grad_.dot(own.completeOrthogonalDecomposition().pseudoInverse() * eg_grad_);
    r_.eg_prior_info_share = alone > 0 && with > 0 ? std::clamp(1.0 - with / alone, 0.0, 1.0) : 0.0;
  }
  char method[160];
  std::snprintf(method, sizeof method, "autocorrelation-corrected (tau=%.1f samples)", tau_);
  spdlog::debug("fit: sigma^2 {:.4g} over {} residuals, tau {:.2f}, rss {:.5g}, {} chunks ({} from the prior)", sigma2_,
                sums_.n_res, tau_, sums_.rss, r_.chunks_simulated + r_.chunks_from_prior, r_.chunks_from_prior);
  r_.se_method = method;
  const size_t g = sums_.chunk_scores.size();
  if (g >= kClusterRobustMinChunks) {
    Eigen::MatrixXd meat = Eigen::MatrixXd::Zero(nf, nf);
    for (const Eigen::VectorXd& sc : sums_.chunk_scores) {
      Eigen::VectorXd sf(nf);
      for (int a = 0; a < nf; ++a) sf[a] = sc[free[a]];
      meat += sf * sf.transpose();
    }
    const Eigen::MatrixXd cov_cluster = jtj_inv * meat * jtj_inv * (static_cast<double>(g) / (g - 1.0));
    if (eg_grad_.dot(cov_cluster * eg_grad_) > eg_grad_.dot(cov_ * eg_grad_)) {
      cov_ = cov_cluster;
      r_.se_method = "cluster-robust over " + std::to_string(g) + " chunks";
    }
  }
}

void FitStatistics::Estimates() {
  const std::vector<int>& free = box_.free;
  const int np = np_, nf = nf_;
  auto estimate = [&](int i) {
    const ParameterBox::Bound& bound = box_.bounds[i];
    ParameterEstimate pe;
    pe.name = settings_.spec.param_name(i);
    pe.unit = settings_.spec.param_unit(i);
    pe.value = theta_[i] * box_.scale[i];
    pe.fixed = bound.fixed;
    pe.at_bound = !pe.fixed && AtBound(pe.value, bound.lower, bound.upper);
    for (int a = 0; a < nf; ++a) {
      if (free[a] == i) pe.se = std::sqrt(std::max(0.0, cov_(a, a))) * box_.scale[i];
    }
    return pe;
  };
  for (int i = 0; i < model::kNumParams; ++i) r_.params[i] = estimate(i);
  for (int i = model::kNumParams; i < np; ++i) r_.effect_params.push_back(estimate(i));
  r_.correlation.assign(static_cast<size_t>(np * np), 0.0);
  for (int i = 0; i < np; ++i) r_.correlation[static_cast<size_t>(i * np + i)] = 1.0;
  for (int a = 0; a < nf; ++a)
    for (int b = 0; b < nf; ++b) {
      const double d = std::sqrt(cov_(a, a) * cov_(b, b));
      r_.correlation[static_cast<size_t>(free[a] * np + free[b])] = d > 0 ? cov_(a, b) / d : 0.0;
    }

  // EG and its standard error by the delta method.
  r_.eg_rad_per_mps2 = eg_rad_per_mps2_;
  r_.eg_se_rad_per_mps2 = std::sqrt(std::max(0.0, eg_grad_.dot(cov_ * eg_grad_)));
  r_.eg_deg_per_g = model::EgToDegPerG(r_.eg_rad_per_mps2);
  r_.eg_se_deg_per_g = model::EgToDegPerG(r_.eg_se_rad_per_mps2);
}

void FitStatistics::BoundShift() {
  const std::vector<int>& free = box_.free;
  const int np = np_, nf = nf_;
  Eigen::VectorXd grad = Eigen::VectorXd::Zero(np);
  for (const Eigen::VectorXd& sc : sums_.chunk_scores) grad += sc;
  Eigen::MatrixXd hp = Eigen::MatrixXd::Zero(np, np);
  priors_.AddPull(theta_.data(), grad, hp);
  Eigen::MatrixXd hf(nf, nf);
  Eigen::VectorXd gf(nf);
  for (int a = 0; a < nf; ++a) {
    gf[a] = grad[free[a]];
    for (int b = 0; b < nf; ++b) hf(a, b) = jtj_f_(a, b) + hp(free[a], free[b]);
  }
  const Eigen::MatrixXd hinv = hf.completeOrthogonalDecomposition().pseudoInverse();
  const Eigen::VectorXd v = hinv * eg_grad_;  // EG's move per unit of -gradient
  r_.eg_bound_shift_rad_per_mps2 = -v.dot(gf);
  for (int a = 0; a < nf; ++a) {
    ParameterEstimate& pe = EstimateOfFree(a);
    if (pe.at_bound) pe.eg_release_shift_rad_per_mps2 = -v[a] * gf[a];
  }
}

void FitStatistics::EgCorrelations() {
  const Eigen::VectorXd cg = cov_ * eg_grad_;
  const double var_eg = eg_grad_.dot(cg);
  for (int a = 0; a < nf_; ++a) {
    ParameterEstimate& pe = EstimateOfFree(a);
    const double d = std::sqrt(std::max(0.0, cov_(a, a)) * std::max(0.0, var_eg));
    pe.eg_correlation = d > 0 ? cg[a] / d : 0.0;
  }
}

void FitStatistics::Halves() {
  r_.eg_se_fit_rad_per_mps2 = r_.eg_se_rad_per_mps2;
  const HalfMoments* halves = sums_.halves;
  if (!(halves[0].drives > 0 && halves[1].drives > 0)) return;
  HalvesContext hc;
  hc.theta = theta_;
  hc.scale = box_.scale;
  for (int i : box_.free)
    if (!AtBound(theta_[i] * box_.scale[i], box_.bounds[i].lower, box_.bounds[i].upper)) hc.free.push_back(i);
  hc.prior_info = priors_.InformationAll(theta_.data(), np_);
  hc.noise_level = sigma2_ * tau_;
  hc.wheelbase_m = settings_.wheelbase_m;
  r_.halves = EstimateHalves(halves[0], halves[1], hc);
  r_.eg_se_rad_per_mps2 = HonestSigma(r_.eg_se_fit_rad_per_mps2, r_.halves->first, r_.halves->second);
  r_.eg_se_deg_per_g = model::EgToDegPerG(r_.eg_se_rad_per_mps2);
  if (r_.eg_se_rad_per_mps2 > r_.eg_se_fit_rad_per_mps2)
    r_.se_method += " x" + std::to_string(r_.eg_se_rad_per_mps2 / r_.eg_se_fit_rad_per_mps2).substr(0, 4) +
                    " (the halves' disagreement)";
}

}  // namespace ndsid::identify
