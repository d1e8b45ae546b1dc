// After the ladder: each output's held-out residual against its noise floor (issue 11 item 4).
// Synthetic segments with white noise (tests/identify/synthetic_segments.h), so the true model's
// RMSE equals the noise and the floor finds it; a hidden effect the ladder may not add leaves its
// output clearly above the floor.
#include <gtest/gtest.h>

#include <cmath>

#include "ndsid/discover/diagnosis.h"
#include "synthetic_segments.h"

namespace ndsid::testing {
namespace {

constexpr double kNoiseA = 0.05;                 // m/s^2
constexpr double kNoiseR = 0.1 * M_PI / 180.0;  // rad/s
constexpr double kDeg = M_PI / 180.0;

config::IdentificationConfig Cfg(bool yaw_rate) {
  config::IdentificationConfig c = DefaultIdentificationConfig();
  c.yaw_rate_output = yaw_rate;
  return c;
}

std::vector<double> BaseTruth() {
  const auto p = TruthParams();
  return {p.m, p.Jz, p.cv, p.ch, p.lv, p.is};
}

const discover::OutputVerdict& Verdict(const discover::Ladder& l, const std::string& output) {
  for (const auto& v : l.verdicts)
    if (v.output == output) return v;
  throw std::runtime_error("no verdict for " + output);
}

discover::Ladder Climb(bool yaw_rate, const std::vector<stats::Segment>& train, const std::vector<stats::Segment>& valid,
                       std::vector<std::string> candidates) {
  discover::LadderOptions o;
  o.align = false;
  o.max_steps = 1;
  o.diagnosis.candidates = std::move(candidates);
  const discover::Ladder l = discover::ClimbErrorLadder(Cfg(yaw_rate), kWheelbase, {}, model::EffectLibrary::Builtin(),
                                                        Pointers(train), Pointers(valid), o);
  for (const auto& v : l.verdicts) std::printf("  %s\n", v.text.c_str());
  return l;
}

// Catches: a floor that is not the noise (the true model would be called unexplained, or any
// model explained), a ratio on the wrong residuals.
TEST(OutputVerdict, CleanDataIsExplainedAtTheNoise) {
  for (uint64_t seed : {201, 202, 203}) {
    const auto train = SyntheticSegments(12, 60.0, kNoiseA, seed);
    const auto valid = SyntheticSegments(4, 60.0, kNoiseA, seed + 100);
    const discover::Ladder l = Climb(false, train, valid, {"steer_offset"});
    ASSERT_EQ(l.verdicts.size(), 1u) << "a_y alone: one verdict";
    const auto& a = Verdict(l, "a_y");
    EXPECT_FALSE(a.unexplained) << a.text;
    EXPECT_NEAR(a.floor, kNoiseA, 0.1 * kNoiseA);
    EXPECT_NEAR(a.rmse, kNoiseA, 0.1 * kNoiseA);
    EXPECT_LT(a.ratio, 1.15);
  }
}

// Catches: a residual left by a missing effect that the verdict passes. The steering offset
// (1.5 deg) is hidden; a ladder that may only try tyre_saturation cannot explain it, one that
// may try steer_offset adds it and ends explained.
TEST(OutputVerdict, HiddenEffectOutsideTheCandidatesIsUnexplained) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"steer_offset"});
  std::vector<double> truth = BaseTruth();
  truth.push_back(1.5 * kDeg);
  for (uint64_t seed : {211, 212}) {
    const auto train = SyntheticSegmentsWithEffects(spec, truth, 12, 60.0, kNoiseA, seed);
    const auto valid = SyntheticSegmentsWithEffects(spec, truth, 4, 60.0, kNoiseA, seed + 100);
    const discover::Ladder without = Climb(false, train, valid, {"tyre_saturation"});
    const auto& a = Verdict(without, "a_y");
    EXPECT_TRUE(a.unexplained) << a.text;
    EXPECT_GT(a.ratio, 1.5);
    EXPECT_NE(a.text.find("unexplained"), std::string::npos);
    const discover::Ladder with = Climb(false, train, valid, {"steer_offset"});
    ASSERT_EQ(with.rungs.size(), 2u);
    EXPECT_FALSE(Verdict(with, "a_y").unexplained) << Verdict(with, "a_y").text;
  }
}

// Catches: a yaw-rate verdict missing with two outputs, or judged on a_y. A gyro offset of
// 0.4 deg/s moves only the yaw rate (the base model does not read it): a_y stays explained and
// the yaw rate is flagged until gyro_offset is added.
TEST(OutputVerdict, TwoOutputsEachOutputJudgedOnItsOwnResidual) {
  const model::ModelSpec spec = model::ModelSpec::FromNames({"gyro_offset"});
  std::vector<double> truth = BaseTruth();
  truth.push_back(0.4 * kDeg);
  const auto train = SyntheticTwoOutputSegments(spec, truth, 12, 60, kNoiseA, kNoiseR, 221);
  const auto valid = SyntheticTwoOutputSegments(spec, truth, 4, 60, kNoiseA, kNoiseR, 321);
  const discover::Ladder without = Climb(true, train, valid, {"tyre_saturation"});
  ASSERT_EQ(without.verdicts.size(), 2u);
  EXPECT_FALSE(Verdict(without, "a_y").unexplained) << Verdict(without, "a_y").text;
  const auto& r = Verdict(without, "yaw rate");
  EXPECT_TRUE(r.unexplained) << r.text;
  EXPECT_EQ(r.unit, "deg/s");
  EXPECT_NEAR(r.floor, 0.1, 0.01);  // the gyro's white noise, in deg/s
  const discover::Ladder with = Climb(true, train, valid, {"gyro_offset"});
  ASSERT_EQ(with.rungs.size(), 2u);
  EXPECT_FALSE(Verdict(with, "yaw rate").unexplained) << Verdict(with, "yaw rate").text;
  EXPECT_FALSE(Verdict(with, "a_y").unexplained) << Verdict(with, "a_y").text;
}

}  // namespace
}  // namespace ndsid::testing
