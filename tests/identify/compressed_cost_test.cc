// The chunk cost Ceres sees (CompressedChunkCost, src/identify/chunk_cost.h): np + 1 residuals
// [Q'r; s] and Jacobian [R; 0] in place of a chunk's m residuals and m x np Jacobian. It must give
// the solver the same cost, gradient and Gauss-Newton matrix as the chunk's own residuals, and
// its kept evaluation must never answer for other parameters or output weights.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <memory>
#include <random>
#include <vector>

#include "chunk_cost.h"
#include "synthetic_segments.h"

namespace ndsid::identify {
namespace {

namespace t = ndsid::testing;
using RowMajor = Eigen::Matrix<double, Eigen::Dynamic, Eigen::Dynamic, Eigen::RowMajor>;

struct Eval {
  double cost;  // |r|^2 / 2
  Eigen::VectorXd gradient;  // J'r
  Eigen::MatrixXd gn;        // J'J
};

Eval EvaluateFull(const ceres::CostFunction& f, const std::vector<double>& theta) {
  const int np = static_cast<int>(theta.size()), m = f.num_residuals();
  std::vector<double> r(static_cast<size_t>(m)), jac(static_cast<size_t>(m) * np);
  const double* p[] = {theta.data()};
  double* j[] = {jac.data()};
  EXPECT_TRUE(f.Evaluate(p, r.data(), j));
  const Eigen::Map<const RowMajor> J(jac.data(), m, np);
  const Eigen::Map<const Eigen::VectorXd> e(r.data(), m);
  return {0.5 * e.squaredNorm(), J.transpose() * e, J.transpose() * J};
}

double CostOnly(const ceres::CostFunction& f, const std::vector<double>& theta) {
  std::vector<double> r(static_cast<size_t>(f.num_residuals()));
  const double* p[] = {theta.data()};
  EXPECT_TRUE(f.Evaluate(p, r.data(), nullptr));
  return 0.5 * Eigen::Map<const Eigen::VectorXd>(r.data(), static_cast<long>(r.size())).squaredNorm();
}

void ExpectSame(const Eval& full, const Eval& comp, const std::string& where) {
  EXPECT_NEAR(comp.cost, full.cost, 1e-12 * full.cost) << where;
  const double gscale = full.gn.diagonal().cwiseSqrt().maxCoeff() * std::sqrt(2 * full.cost);
  EXPECT_LE((comp.gradient - full.gradient).cwiseAbs().maxCoeff(), 1e-10 * gscale) << where;
  EXPECT_LE((comp.gn - full.gn).cwiseAbs().maxCoeff(), 1e-10 * full.gn.cwiseAbs().maxCoeff()) << where;
}

// Catches: a factorisation that drops the part of r outside J's columns (s) or mis-signs Q'r, a
// residual-only evaluation with another cost, a kept evaluation answered for changed parameters
// or output weights. Two outputs with road_bank and gyro_offset, a_y-only and yaw-rate chunks,
// at the start values and at perturbed parameters, two seeds.
TEST(CompressedChunkCost, GivesTheSolverTheChunksCostGradientAndGaussNewtonMatrix) {
  const model::ModelSpec truth_spec = model::ModelSpec::FromNames({"crossfall", "gyro_offset"});
  std::vector<double> truth = t::TruthVector();
  truth.push_back(0.0);
  truth.push_back(0.3 * M_PI / 180.0);
  const model::ModelSpec spec = model::ModelSpec::FromNames({"road_bank", "gyro_offset"});
  const int np = spec.num_params();
  for (const uint64_t seed : {5u, 6u}) {
    const auto segs = t::SyntheticTwoOutputSegments(truth_spec, truth, 3, 40, 0.05, 0.1 * M_PI / 180.0, seed, 0.2);
    const std::vector<Chunk> chunks = MakeChunks(t::Pointers(segs), 20.0, 1.5);
    ASSERT_GE(chunks.size(), 3u);
    // The identifier's scaling: base parameters by their value, effects by half their box.
    std::vector<double> start = t::TruthVector(), scale = t::TruthVector();
    for (int i = model::kNumParams; i < np; ++i) {
      start.push_back(spec.effect_param(i)->initial + 0.1 * (spec.effect_param(i)->upper - spec.effect_param(i)->lower));
      scale.push_back(0.5 * (spec.effect_param(i)->upper - spec.effect_param(i)->lower));
    }
    std::mt19937_64 rng(seed);
    std::normal_distribution<double> jitter(0.0, 0.03);
    for (const Chunk& c : chunks) {
      auto weights = std::make_shared<OutputWeights>();
      weights->yaw_rate = 1.0;
      auto full = MakeChunkCost(c, BurnInSamples(c, 1.5), t::kWheelbase, spec, scale, weights);
      CompressedChunkCost comp(MakeChunkCost(c, BurnInSamples(c, 1.5), t::kWheelbase, spec, scale, weights), weights);
      ASSERT_EQ(comp.num_residuals(), np + 1);
      ASSERT_GT(full->num_residuals(), 10 * np);
      std::vector<double> theta(static_cast<size_t>(np));
      for (int i = 0; i < np; ++i) theta[static_cast<size_t>(i)] = start[static_cast<size_t>(i)] / scale[static_cast<size_t>(i)];
      for (int round = 0; round < 3; ++round) {
        const std::string where = "seed " + std::to_string(seed) + " round " + std::to_string(round);
        const Eval f = EvaluateFull(*full, theta);
        ExpectSame(f, EvaluateFull(comp, theta), where);
        ExpectSame(f, EvaluateFull(comp, theta), where + " (kept)");  // answered from the kept evaluation
        EXPECT_NEAR(CostOnly(comp, theta), CostOnly(*full, theta), 1e-12 * f.cost) << where;
        // Other output weights at the same parameters: not the kept evaluation.
        weights->a_y = 0.5 + round;
        ExpectSame(EvaluateFull(*full, theta), EvaluateFull(comp, theta), where + " (new weights)");
        for (double& x : theta) x *= 1.0 + jitter(rng);  // other parameters
      }
    }
  }
}

}  // namespace
}  // namespace ndsid::identify
