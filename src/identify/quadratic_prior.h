// The incremental update's prior as a Ceres cost (private to the identify stage): the sum of
// the prior's chunk quadratics (linearized_window.h), and the helpers the update's guards use.
#pragma once

#include <ceres/ceres.h>

#include <Eigen/Dense>
#include <vector>

#include "ndsid/identify/linearized_window.h"
#include "ndsid/stats/segment.h"

namespace ndsid::identify {

// The sum of the prior's chunk quadratics, sum_c rss_c + 2 s_c'd_c + d_c' H_c d_c (d_c = theta -
// theta_c), as residuals A theta - c with A'A = H = sum H_c and A'c = b = sum (H_c theta_c - s_c):
// A = L^(1/2) V' over H's eigenpairs (V, L) above a relative floor.
// A direction the prior does not determine at all (L_k at the floor, e.g. a fixed parameter's or
// m's scaling direction when m is free) is held near the start theta0 (the last estimate) with a
// standard deviation of 1 (the parameter's scale) by a second row sqrt(level) v_k'(theta - theta0),
// so the solver cannot wander along it.
class QuadraticPrior final : public ceres::CostFunction {
 public:
  explicit QuadraticPrior(int np) : np_(np) {
    set_num_residuals(2 * np);
    mutable_parameter_block_sizes()->push_back(np);
  }
  int weak_directions() const { return weak_; }
  // The quadratics of `chunks`; level: the prior's noise level sigma^2 tau; theta0: the start.
  void Set(const std::vector<const LinearizedChunk*>& chunks, double level, const std::vector<double>& theta0);
  bool Evaluate(double const* const* p, double* r, double** jac) const override {
    const Eigen::Map<const Eigen::VectorXd> theta(p[0], np_);
    Eigen::Map<Eigen::VectorXd>(r, 2 * np_) = a_ * theta - c_;
    if (jac && jac[0]) Eigen::Map<Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>>(jac[0], 2 * np_, np_) = a_;
    return true;
  }

 private:
  int np_;
  Eigen::MatrixXd a_;
  Eigen::VectorXd c_;
  int weak_ = 0;
};

// d EG / d theta (scaled parameters, p_i = theta_i * scale_i) at theta: the six base parameters'
// entries, 0 for fixed ones (fixed[i]) and for effects.
Eigen::VectorXd EgGradientTheta(const std::vector<double>& theta, const std::vector<double>& scale, double wheelbase_m,
                                const std::vector<bool>& fixed);

// The EG check of an incremental solution (identifier.cc, docs/incremental.md): one sampled
// prior chunk, simulated at the solution. Along v = H^-1 g (H the prior's J'J, g EG's gradient):
// its true score v.(J'e) and |Jv|^2, against its quadratic's predictions v.(s_c + H_c d) and
// v'H_c v.
struct EgCheckSample {
  double vs = 0, vs_pred = 0, vhv = 0, vhv_pred = 0;
};

// The check's estimates from a sample of the prior's `total` chunks, scaled to all of them:
//   shift  |total/n sum(vs - vs_pred)| / sd       EG's move, in its standard deviations sd;
//   bread  |total/n sum(vhv - vhv_pred)| / g'H^-1g  the relative error of EG's variance's bread;
//   meat   |sum(vs^2 - vs_pred^2)| / sum(vs_pred^2) that of its cluster-robust meat (a ratio).
// Each with its standard error from the spread of the sampled chunks' terms, as for a simple
// random sample of the chunks (the sums scaled: total s / sqrt(n); the ratio's by the jackknife,
// infinite where leaving one chunk out leaves no predicted meat); 0 below two samples.
struct EgCheckEstimates {
  size_t sampled = 0;
  double shift = 0, shift_se = 0;
  double bread = 0, bread_se = 0;
  double meat = 0, meat_se = 0;
  // Every estimate within its limit with kEgCheckClearZ of its standard errors to spare (false
  // below two samples): a smaller sample already decides the check.
  bool clear(double eg_limit, double sigma_limit) const;
};
inline constexpr double kEgCheckClearZ = 2.0;
EgCheckEstimates EstimateEgCheck(const std::vector<EgCheckSample>& samples, size_t total, double sd, double g_hinv_g);

// The prior's segment and the window's are the same data (drive, start and length).
bool SameSegment(const LinearizedSegment& l, const stats::Segment& s);

}  // namespace ndsid::identify
