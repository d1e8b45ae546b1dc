// The chunk cost Ceres sees (CompressedChunkCost, src/identify/chunk_cost.h): np + 1 residuals
// [Q'r; s] and Jacobian [R; 0] in place of a chunk's m residuals and m x np Jacobian. It must give
// the solver the same cost, gradient and Gauss-Newton matrix as the chunk's own residuals, and
// its kept evaluation must never answer for other parameters or output weights.
#include <gtest/gtest.h>

#include <Eigen/Dense>
#include <cmath>
#include <memory>
#include <random>
#include <string>
#include <type_traits>
#include <vector>

#include "chunk_cost.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/identify/linearized_window.h"
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
  const auto [truth_spec, truth] = t::CrossfallGyroOffsetTruth();
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


// Catches: a Jet width whose derivatives differ from the other's, an effect term missing or wrong
// for one of them (effect.h declares each term for double, Jet and SmallJet), a model that the
// cost builds on the wrong width. The fit computes a model of at most kSmallJetSize parameters on
// SmallJet (one pass) and every other on Jet: both must give the same residuals and Jacobian,
// bit for bit. Every built-in effect on its own, the road_bank + gyro_offset model of the
// example, and all effects together (SmallJet then in two passes), at perturbed parameters.
TEST(ChunkCost, SmallJetGivesTheWideJetsResidualsAndJacobianBitForBit) {
  const auto [truth_spec, truth] = t::CrossfallGyroOffsetTruth();
  const auto segs = t::SyntheticTwoOutputSegments(truth_spec, truth, 2, 40, 0.05, 0.1 * M_PI / 180.0, 7, 0.2);
  const std::vector<Chunk> chunks = MakeChunks(t::Pointers(segs), 20.0, 1.5);
  ASSERT_GE(chunks.size(), 2u);
  std::vector<std::vector<std::string>> models = {{}, {"road_bank", "gyro_offset"}};
  std::vector<std::string> all;
  for (const std::string& name : model::BuiltinEffectNames()) {
    models.push_back({name});
    if (name != "gyro_offset_per_drive") all.push_back(name);  // it shares gyro_offset's parameter
  }
  models.push_back(all);
  std::mt19937_64 rng(7);
  std::uniform_real_distribution<double> u(-0.2, 0.2);
  for (const auto& names : models) {
    const model::ModelSpec spec = model::ModelSpec::FromNames(names);
    const int np = spec.num_params();
    std::vector<double> scale = t::TruthVector(), theta(static_cast<size_t>(np), 1.0);
    for (int i = model::kNumParams; i < np; ++i) scale.push_back(0.5 * (spec.effect_param(i)->upper - spec.effect_param(i)->lower));
    for (int i = model::kNumParams; i < np; ++i) {
      const model::EffectParam& e = *spec.effect_param(i);
      theta[static_cast<size_t>(i)] = (e.initial + 0.1 * (e.upper - e.lower)) / scale[static_cast<size_t>(i)];
    }
    for (double& x : theta) x *= 1.0 + u(rng);
    const std::string where = spec.Describe() + " (" + std::to_string(np) + " parameters)";
    for (const Chunk& c : chunks) {
      auto weights = std::make_shared<const OutputWeights>(OutputWeights{1.0, 1.0});
      auto make = [&](auto stride) {
        using Cost = ceres::DynamicAutoDiffCostFunction<ChunkResidual, decltype(stride)::value>;
        auto* functor = new ChunkResidual(c, BurnInSamples(c, 1.5), t::kWheelbase, spec, scale, weights);
        auto cost = std::make_unique<Cost>(functor);  // owns the functor
        cost->AddParameterBlock(np);
        cost->SetNumResiduals(static_cast<int>(functor->num_residuals()));
        return cost;
      };
      const auto small = make(std::integral_constant<int, model::kSmallJetSize>{});
      const auto wide = make(std::integral_constant<int, model::kJetSize>{});
      const int m = wide->num_residuals();
      ASSERT_GT(m, 0) << where;
      std::vector<double> rs(static_cast<size_t>(m)), rw(rs.size()), js(rs.size() * np), jw(js.size());
      const double* p[] = {theta.data()};
      double* jsp[] = {js.data()};
      double* jwp[] = {jw.data()};
      ASSERT_TRUE(small->Evaluate(p, rs.data(), jsp)) << where;
      ASSERT_TRUE(wide->Evaluate(p, rw.data(), jwp)) << where;
      for (size_t k = 0; k < rs.size(); ++k) ASSERT_EQ(rs[k], rw[k]) << where << " residual " << k;
      size_t nonzero = 0;
      for (size_t k = 0; k < js.size(); ++k) {
        ASSERT_EQ(js[k], jw[k]) << where << " Jacobian element " << k;
        nonzero += js[k] != 0.0 ? 1 : 0;
      }
      EXPECT_GT(nonzero, js.size() / 4) << where;  // the derivatives were computed, not left at 0
      // The cost the identifier builds takes the narrower Jet exactly when the model fits in it.
      const auto built = MakeChunkCost(c, BurnInSamples(c, 1.5), t::kWheelbase, spec, scale, weights);
      using SmallCost = ceres::DynamicAutoDiffCostFunction<ChunkResidual, model::kSmallJetSize>;
      const bool built_small = dynamic_cast<const SmallCost*>(built.get()) != nullptr;
      EXPECT_EQ(built_small, np <= model::kSmallJetSize) << where;
    }
  }
}

// Catches: a re-weighting that scales the wrong part (the yaw rate's against a_y's), forgets the
// score, the sum of squares or the autocorrelation sums, or a yaw-rate part kept with the wrong
// rows. A two-output fit keeps its chunks' quadratics; re-weighted to other output weights they
// must be those computed directly with the other weights at the same points. Two seeds, the
// yaw rate's weight raised and lowered against a_y's.
TEST(LinearizedWindow, ReweightedIsTheQuadraticBuiltWithTheOtherWeights) {
  const auto [truth_spec, truth] = t::CrossfallGyroOffsetTruth();
  const model::ModelSpec spec = model::ModelSpec::FromNames({"road_bank", "gyro_offset"});
  config::IdentificationConfig cfg = t::DefaultIdentificationConfig();
  cfg.yaw_rate_output = true;
  for (const uint64_t seed : {11u, 12u}) {
    const auto segs = t::SyntheticTwoOutputSegments(truth_spec, truth, 6, 60, 0.05, 0.1 * M_PI / 180.0, seed, 0.2);
    const Identifier id(cfg, t::kWheelbase, spec);
    const IdentificationResult fit = id.Identify(t::Pointers(segs), {}, std::nullopt, IncrementalUpdate{nullptr, 2.0, true});
    ASSERT_TRUE(fit.valid && fit.linearized) << fit.reason;
    const LinearizedWindow& lw = *fit.linearized;
    ASSERT_TRUE(lw.Reweightable());
    ASSERT_EQ(lw.segments.size(), segs.size());
    for (const auto& [fa, fr] : {std::pair{1.0, 1.4}, std::pair{2.0, 0.5}}) {
      const double wa = fa * lw.weight_a_y, wr = fr * lw.weight_yaw_rate;
      const LinearizedWindow re = lw.Reweighted(wa, wr);
      EXPECT_EQ(re.weight_a_y, wa);
      EXPECT_EQ(re.weight_yaw_rate, wr);
      const int np = static_cast<int>(lw.scale.size());
      for (size_t si = 0; si < segs.size(); ++si) {
        const std::vector<Chunk> chunks = MakeChunks({&segs[si]}, cfg.chunk_s, cfg.burn_in_s);
        ASSERT_EQ(chunks.size(), re.segments[si].chunks.size());
        for (size_t k = 0; k < chunks.size(); ++k) {
          const LinearizedChunk& lc = re.segments[si].chunks[k];
          auto weights = std::make_shared<const OutputWeights>(OutputWeights{wa, wr});
          const auto cost = MakeChunkCost(chunks[k], BurnInSamples(chunks[k], cfg.burn_in_s), t::kWheelbase, spec, lw.scale, weights);
          const Eval direct = EvaluateFull(*cost, lc.theta);
          const std::string where = "seed " + std::to_string(seed) + " segment " + std::to_string(si) + " chunk " + std::to_string(k);
          const Eigen::Map<const RowMajor> h(lc.jtj.data(), np, np);
          const Eigen::Map<const Eigen::VectorXd> sc(lc.score.data(), np);
          EXPECT_LE((h - direct.gn).cwiseAbs().maxCoeff(), 1e-9 * direct.gn.cwiseAbs().maxCoeff()) << where;
          EXPECT_LE((sc - direct.gradient).cwiseAbs().maxCoeff(), 1e-9 * direct.gradient.cwiseAbs().maxCoeff() + 1e-12) << where;
          EXPECT_NEAR(lc.rss, 2 * direct.cost, 1e-9 * 2 * direct.cost) << where;
          // The sums of squares per output are unweighted and stay; the lag-0 sums are weighted.
          EXPECT_NEAR(lc.acf_a_y[0], wa * wa * lc.rss_a_y, 1e-9 * lc.acf_a_y[0]) << where;
          EXPECT_NEAR(lc.acf_yaw_rate[0], wr * wr * lc.rss_yaw_rate, 1e-9 * lc.acf_yaw_rate[0]) << where;
        }
      }
    }
  }
}

}  // namespace
}  // namespace ndsid::identify
