// The statistics of a fit at its optimum (private to the identify stage), from the sums there
// (optimum_sums.h): the covariance of the free parameters, the estimates with their standard
// errors and correlations, EG and its standard error by the delta method, the box's pull on EG
// (the shift of EG were the bounded parameters released), each parameter's correlation with EG,
// the EG of the window's two halves, and the identifiability report. Each step fills its part of
// the result, in the order of the members below.
#pragma once

#include <Eigen/Dense>

#include <cstddef>
#include <vector>

#include "evidence_priors.h"
#include "fit_problem.h"
#include "optimum_sums.h"

namespace ndsid::identify {

class FitStatistics {
 public:
  FitStatistics(const FitSettings& settings, const ParameterBox& box, const std::vector<double>& theta,
                const EvidencePriors& priors, const OptimumSums& sums, IdentificationResult& result);

  // Two honest covariances for autocorrelated residuals; the one more cautious about EG wins:
  // the classical one inflated by the residuals' integrated autocorrelation time (from the pooled
  // sums when incremental, else from the residual series), and (with enough chunks) the
  // cluster-robust sandwich over chunks. Sets the result's se_method.
  void Covariance(bool incremental);
  // Every parameter's value, standard error and bound, their correlations, EG and its standard
  // error by the delta method.
  void Estimates();
  // The box's pull on EG (the checks of the fit): the Newton step from the estimate with every
  // bound released, -(J'J + priors)^-1 g (g the gradient there, the data's scores and the priors'
  // pull: at an interior optimum 0 but for the parameters the box holds), and EG's move along it,
  // in total and for each parameter released alone.
  void BoundShift();
  // Each parameter's correlation with EG (the checks of the fit: a bound that moves EG).
  void EgCorrelations();
  // The halves (alternate training drives): their EGs for the checks of the fit, and sigma(EG)
  // widened where they disagree beyond kHalvesCoverZ combined sigma.
  void Halves();
  // Singular values of the column-scaled Jacobian over the free parameters, the directions the
  // data do not determine, and notes on the parameters, the outputs (chunks_with_yaw of `chunks`
  // have a yaw rate) and the priors (identifiability.cc).
  void Identifiability(bool two_outputs, size_t chunks_with_yaw, size_t chunks);

 private:
  ParameterEstimate& EstimateOfFree(int a);

  const FitSettings& settings_;
  const ParameterBox& box_;
  const std::vector<double>& theta_;  // the optimum
  const EvidencePriors& priors_;
  const OptimumSums& sums_;
  IdentificationResult& r_;
  const int np_;                // parameters of the model
  const int nf_;                // of them free
  Eigen::MatrixXd jtj_f_;       // J'J over the free parameters (theta space)
  double sigma2_ = 0;           // the weighted residuals' variance
  double tau_ = 0;              // their integrated autocorrelation time [samples]
  Eigen::MatrixXd cov_;         // the free parameters' covariance (theta space)
  Eigen::VectorXd eg_grad_;     // d EG / d theta over the free parameters (0 for effects)
  double eg_rad_per_mps2_ = 0;  // EG at the optimum
};

}  // namespace ndsid::identify
