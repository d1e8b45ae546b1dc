#include "ndsid/identify/identifier.h"

#include <gtest/gtest.h>

#include "ndsid/config/config.h"
#include "synthetic_segments.h"

namespace ndsid::identify {
namespace {

using ndsid::testing::kWheelbase;
using ndsid::testing::Pointers;
using ndsid::testing::SyntheticSegments;
using ndsid::testing::TruthParams;

config::IdentificationConfig DefaultConfig() { return ndsid::testing::DefaultIdentificationConfig(); }

// Catches: a wrong model, discretisation or parameter scaling biasing EG; an optimiser that
// stops early. Data: 40 segments x 60 s, a_y noise 0.05 m/s^2, the truth inside the box.
TEST(Identifier, RecoversEgWithinOnePercentOfTruth) {
  const auto train = SyntheticSegments(40, 60, 0.05, 1);
  const auto valid = SyntheticSegments(10, 60, 0.05, 2);
  const Identifier id(DefaultConfig(), kWheelbase);
  const IdentificationResult r = id.Identify(Pointers(train), Pointers(valid));
  ASSERT_TRUE(r.valid) << r.reason;
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);
  EXPECT_NEAR(r.eg_rad_per_mps2, eg_true, 0.01 * eg_true);
  EXPECT_NEAR(r.params[model::kSteerRatio].value, 14.8, 0.05);
  EXPECT_NEAR(r.params[model::kCgToFront].value, 1.15, 0.03);
  EXPECT_TRUE(r.params[model::kMass].fixed);
  EXPECT_DOUBLE_EQ(r.params[model::kMass].value, 1900.0);
  // White noise of 0.05: the fitted RMSE can only approach it.
  EXPECT_NEAR(r.rmse_train_mps2, 0.05, 0.003);
  EXPECT_NEAR(r.rmse_validation_mps2, 0.05, 0.003);
  EXPECT_GT(r.eg_se_rad_per_mps2, 0.0);
  EXPECT_LT(std::abs(r.eg_rad_per_mps2 - eg_true), 4 * r.eg_se_rad_per_mps2 + 1e-9);
}

// Catches: identifiability hidden from the user. With m free, scaling (m, Jz, cv, ch) leaves a_y
// unchanged: the report must name that direction, and EG must still come out right.
TEST(Identifier, FreeMassIsReportedAsNotDetermined) {
  auto cfg = DefaultConfig();
  cfg.params[model::kMass].fixed = false;
  const auto train = SyntheticSegments(20, 60, 0.05, 3);
  const Identifier id(cfg, kWheelbase);
  const IdentificationResult r = id.Identify(Pointers(train), {});
  ASSERT_TRUE(r.valid) << r.reason;
  ASSERT_FALSE(r.identifiability.weak.empty());
  const std::string& d = r.identifiability.weak.front().description;
  EXPECT_NE(d.find(" m"), std::string::npos) << d;
  EXPECT_NE(d.find("cv"), std::string::npos) << d;
  EXPECT_NE(d.find("ch"), std::string::npos) << d;
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);
  EXPECT_NEAR(r.eg_rad_per_mps2, eg_true, 0.02 * eg_true);
}

// Catches: an RMSE evaluator that disagrees with the fit's own residuals.
TEST(Identifier, RmseAtTruthEqualsNoiseLevel) {
  const auto segs = SyntheticSegments(10, 60, 0.08, 4);
  const Identifier id(DefaultConfig(), kWheelbase);
  size_t n = 0;
  const double rmse = id.Rmse(TruthParams(), Pointers(segs), &n);
  EXPECT_GT(n, 20000u);
  EXPECT_NEAR(rmse, 0.08, 0.004);
}

TEST(Identifier, NoDataIsNotValidWithReason) {
  const Identifier id(DefaultConfig(), kWheelbase);
  const IdentificationResult r = id.Identify({}, {});
  EXPECT_FALSE(r.valid);
  EXPECT_FALSE(r.reason.empty());
}

}  // namespace
}  // namespace ndsid::identify
