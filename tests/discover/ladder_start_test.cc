// The ladder's starting fit (LadderOptions::start_fit): `ndsid diagnose` hands it the replay's own
// fit of the starting model, and the ladder climbs from it instead of fitting that model again.
#include <gtest/gtest.h>

#include <cmath>

#include "ndsid/discover/diagnosis.h"
#include "synthetic_segments.h"

namespace ndsid::testing {
namespace {

std::vector<double> BaseTruthPlus(const std::vector<double>& effect_params) {
  std::vector<double> v = TruthVector();
  v.insert(v.end(), effect_params.begin(), effect_params.end());
  return v;
}

discover::Ladder Climb(const std::vector<stats::Segment>& train, const std::vector<stats::Segment>& valid,
                       std::optional<identify::IdentificationResult> start) {
  discover::LadderOptions o;
  o.align = false;
  o.max_steps = 1;
  o.diagnosis.candidates = {"steer_offset", "accel_bias"};
  o.start_fit = std::move(start);
  return discover::ClimbErrorLadder(DefaultIdentificationConfig(), kWheelbase, {"road_bank"}, model::EffectLibrary::Builtin(),
                                    Pointers(train), Pointers(valid), o);
}

// Catches: a ladder that fits its starting model again although it was handed that fit (the
// marker would be gone), one that starts from a fit of another model or an invalid one, or one
// whose climb depends on where its first rung came from. A hidden 1.5 deg steering offset, three
// seeds; the climb from the given fit and from its own must add the same effect, with EGs within
// 0.1 sigma of each other.
TEST(LadderStart, ClimbsFromTheGivenFitOfItsStartingModelAndIgnoresAnyOther) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"steer_offset"});
  for (uint64_t seed : {41u, 42u, 43u}) {
    const auto train = SyntheticSegmentsWithEffects(spec, BaseTruthPlus({1.5 * M_PI / 180}), 12, 60, 0.05, seed);
    const auto valid = SyntheticSegmentsWithEffects(spec, BaseTruthPlus({1.5 * M_PI / 180}), 3, 60, 0.05, seed + 100);
    const identify::Identifier start(DefaultIdentificationConfig(), kWheelbase, model::ModelSpec::FromNames({"road_bank"}));
    identify::IdentificationResult given = start.Identify(Pointers(train), Pointers(valid), std::optional<std::vector<double>>{});
    ASSERT_TRUE(given.valid) << given.reason;
    given.termination = "handed in by the test";  // a marker the ladder's own fit would not carry

    const discover::Ladder from_given = Climb(train, valid, given);
    const discover::Ladder own = Climb(train, valid, std::nullopt);
    ASSERT_GE(from_given.rungs.size(), 2u);
    ASSERT_EQ(from_given.rungs.size(), own.rungs.size());
    EXPECT_EQ(from_given.rungs[0].fit.termination, "handed in by the test") << seed;
    EXPECT_NE(own.rungs[0].fit.termination, "handed in by the test") << seed;
    EXPECT_EQ(from_given.rungs[1].added, "steer_offset") << seed;
    EXPECT_EQ(own.rungs[1].added, "steer_offset") << seed;
    const auto& a = from_given.rungs.back().fit;
    const auto& b = own.rungs.back().fit;
    std::printf("seed %llu: EG from the given fit %.4f ± %.4f, from its own %.4f ± %.4f deg/g\n",
                static_cast<unsigned long long>(seed), a.eg_deg_per_g, a.eg_se_deg_per_g, b.eg_deg_per_g, b.eg_se_deg_per_g);
    EXPECT_LT(std::abs(a.eg_deg_per_g - b.eg_deg_per_g), 0.1 * b.eg_se_deg_per_g) << seed;

    // A fit of another model (the bare single-track), or an invalid one: fitted again.
    identify::IdentificationResult other =
        identify::Identifier(DefaultIdentificationConfig(), kWheelbase).Identify(Pointers(train), Pointers(valid));
    other.termination = "handed in by the test";
    const discover::Ladder from_other = Climb(train, valid, other);
    EXPECT_NE(from_other.rungs[0].fit.termination, "handed in by the test") << seed;
    EXPECT_EQ(from_other.rungs[0].fit.model, own.rungs[0].fit.model) << seed;
    given.valid = false;
    EXPECT_NE(Climb(train, valid, given).rungs[0].fit.termination, "handed in by the test") << seed;
  }
}

}  // namespace
}  // namespace ndsid::testing
