// Evidence priors of a window fit (private to the identify stage): Gaussian priors on single
// parameters from outside the fitted residuals, each one residual of the least-squares problem.
// Three sources, in this order: the configured priors (model.priors), the standstill evidence
// (docs/two-outputs.md) and the speed-scale evidence (stats/speed_scale.h). A configured prior
// on a parameter wins over evidence on it. A new kind of evidence is one more Add... member,
// called from EvidencePriors::Build after the others (the residual blocks' order is the order
// built: append, do not insert, to keep every existing fit's numbers).
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <algorithm>
#include <cmath>
#include <memory>
#include <string>
#include <vector>

#include "fit_problem.h"
#include "ndsid/config/config.h"

namespace ndsid::identify {

// One Gaussian prior as one residual sqrt(w) (g(theta) - value) / sd, with w the data's noise
// level (sigma_e^2 times the residuals' autocorrelation time) so that the sum of squares stays the
// MAP objective of the data's least squares.
class PriorResidual : public ceres::CostFunction {
 public:
  explicit PriorResidual(int np) {
    set_num_residuals(1);
    mutable_parameter_block_sizes()->push_back(np);
  }
  void set_weight(double w) { sqrt_w_ = std::sqrt(w); }
  // Adds the prior's information in theta space at theta (np x np): the outer product of
  // d((g - value) / sd)/dtheta.
  virtual void AddInformation(const double* theta, Eigen::MatrixXd& info) const = 0;

 protected:
  double sqrt_w_ = 0;
};

// A prior on parameter i: g = theta_i scale_i.
class PriorCost final : public PriorResidual {
 public:
  PriorCost(int np, int i, double scale, double value, double sd) : PriorResidual(np), i_(i), scale_(scale), value_(value), sd_(sd) {}
  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    r[0] = sqrt_w_ * (p[0][i_] * scale_ - value_) / sd_;
    if (jac && jac[0]) {
      std::fill(jac[0], jac[0] + parameter_block_sizes()[0], 0.0);
      jac[0][i_] = sqrt_w_ * scale_ / sd_;
    }
    return true;
  }
  void AddInformation(const double*, Eigen::MatrixXd& info) const override { info(i_, i_) += scale_ * scale_ / (sd_ * sd_); }

 private:
  int i_;
  double scale_, value_, sd_;
};

// A prior on the self-steering gradient (model.priors `eg_deg_per_g`, e.g. a fleet group's EG):
// g = EG(m, cv, ch, lv) of the base parameters, in rad/(m/s^2).
class EgPriorCost final : public PriorResidual {
 public:
  EgPriorCost(int np, const std::vector<double>& scale, double wheelbase_m, double value_rad, double sd_rad)
      : PriorResidual(np), scale_(scale), wheelbase_m_(wheelbase_m), value_(value_rad), sd_(sd_rad) {}
  bool Evaluate(double const* const* p, double* r, double** jac) const override;
  void AddInformation(const double* theta, Eigen::MatrixXd& info) const override;

 private:
  // (EG - value) / sd at theta, and its gradient in theta space (np).
  double Standardised(const double* theta, Eigen::VectorXd& row) const;
  std::vector<double> scale_;
  double wheelbase_m_, value_, sd_;
};

// Whether model.priors has a prior on the parameter `name` (it then wins over model-free evidence).
bool HasConfiguredPrior(const config::IdentificationConfig& config, const std::string& name);

// The evidence priors of one fit, with the notes the identifiability report carries about them.
class EvidencePriors {
 public:
  // Every source's priors on the free parameters of `box`, in the order above: standstill
  // evidence from the `stops` of the training drives, speed-scale evidence from the training data.
  void Build(const FitSettings& settings, const ParameterBox& box, const SegmentList& training,
             const std::vector<gate::StandstillStop>& stops);

  bool empty() const { return costs_.empty(); }
  // Adds every prior to `problem` as a residual on theta, in the order built.
  void AddTo(ceres::Problem& problem, double* theta) const;
  // The priors' weight: the noise level of the data's residuals at theta (the scale of a
  // residual's information), taken again wherever the output weights or the fit moved it.
  void SetWeight(double level);
  double weight() const { return weight_; }
  // The priors' information in theta space at theta over the free parameters (zero without
  // priors); configured_only: model.priors' part alone (the vehicle's own evidence left out).
  Eigen::MatrixXd InformationTheta(const double* theta, const std::vector<int>& free, bool configured_only = false) const;
  // The same over every parameter (np x np).
  Eigen::MatrixXd InformationAll(const double* theta, int np, bool configured_only = false) const;
  // Adds the priors' gradient (J'r) at theta into grad and their Gauss-Newton matrix J'J into
  // hessian (np each).
  void AddPull(const double* theta, Eigen::VectorXd& grad, Eigen::MatrixXd& hessian) const;
  // For the identifiability report: the evidence's notes, then one per configured prior.
  std::vector<std::string> Notes() const;

 private:
  void AddConfigured(const FitSettings& settings, const ParameterBox& box);
  void AddEgPrior(const FitSettings& settings, const ParameterBox& box, const config::ParameterPrior& pr);
  void AddStandstill(const FitSettings& settings, const ParameterBox& box, const SegmentList& training,
                     const std::vector<gate::StandstillStop>& stops);
  void AddSpeedScale(const FitSettings& settings, const ParameterBox& box, const SegmentList& training);
  void Add(const ParameterBox& box, int i, double value, double sd);

  std::vector<std::unique_ptr<PriorResidual>> costs_;  // one per prior, in the order built
  size_t configured_ = 0;                              // the first this many are model.priors'
  std::vector<std::string> evidence_notes_;        // what the standstill and speed-scale evidence gave
  std::vector<std::string> prior_notes_;           // one per configured prior applied
  double weight_ = 0;                              // the noise level the priors are weighted with
};

}  // namespace ndsid::identify
