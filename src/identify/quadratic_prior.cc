#include "quadratic_prior.h"

#include <cmath>

#include "ndsid/model/single_track.h"

namespace ndsid::identify {

void QuadraticPrior::Set(const std::vector<const LinearizedChunk*>& chunks, double level, const std::vector<double>& theta0) {
  Eigen::MatrixXd h = Eigen::MatrixXd::Zero(np_, np_);
  Eigen::VectorXd b = Eigen::VectorXd::Zero(np_);
  for (const LinearizedChunk* c : chunks) {
    const Eigen::Map<const Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>> hc(c->jtj.data(), np_, np_);
    const Eigen::Map<const Eigen::VectorXd> th(c->theta.data(), np_), sc(c->score.data(), np_);
    h += hc;
    b += hc * th - sc;
  }
  h = 0.5 * (h + h.transpose());
  Eigen::SelfAdjointEigenSolver<Eigen::MatrixXd> es(h);
  const Eigen::VectorXd lambda = es.eigenvalues();
  const double floor = 1e-12 * std::max(0.0, lambda.maxCoeff());
  a_ = Eigen::MatrixXd::Zero(2 * np_, np_);
  c_ = Eigen::VectorXd::Zero(2 * np_);
  weak_ = 0;
  const Eigen::Map<const Eigen::VectorXd> t0(theta0.data(), np_);
  for (int k = 0; k < np_; ++k) {
    const Eigen::VectorXd v = es.eigenvectors().col(k);
    double w = 0;
    if (lambda[k] > floor) {
      a_.row(k) = std::sqrt(lambda[k]) * v.transpose();
      c_[k] = v.dot(b) / std::sqrt(lambda[k]);
    } else if (level > 0) {
      w = std::sqrt(level);
    }
    if (w > 0) {
      a_.row(np_ + k) = w * v.transpose();
      c_[np_ + k] = w * v.dot(t0);
      ++weak_;
    }
  }
}

Eigen::VectorXd EgGradientTheta(const std::vector<double>& theta, const std::vector<double>& scale, double wheelbase_m,
                                const std::vector<bool>& fixed) {
  using Jet6 = ceres::Jet<double, 6>;
  model::Params<Jet6> pj{Jet6(theta[0] * scale[0], 0), Jet6(theta[1] * scale[1], 1), Jet6(theta[2] * scale[2], 2),
                         Jet6(theta[3] * scale[3], 3), Jet6(theta[4] * scale[4], 4), Jet6(theta[5] * scale[5], 5)};
  const Jet6 eg = model::SelfSteerGradient(pj, wheelbase_m);
  Eigen::VectorXd g = Eigen::VectorXd::Zero(static_cast<int>(theta.size()));
  for (int i = 0; i < model::kNumParams; ++i) g[i] = fixed[i] ? 0.0 : eg.v[i] * scale[i];
  return g;
}

}  // namespace ndsid::identify
