// Per-drive parameters (model::EffectParam::per_drive) through the generic machinery: a gyro
// offset that differs from drive to drive (gyro_offset_per_drive), on synthetic two-output
// drives of the exact model (synthetic_segments.h). The fit must find every drive's offset and
// EG; the diagnosis must score only the spread between drives as per-drive evidence; the ladder
// must replace gyro_offset by its per-drive form when the offsets differ.
#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>

#include "ndsid/common/error.h"
#include "ndsid/discover/diagnosis.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/identify/result_codec.h"
#include "synthetic_segments.h"

namespace ndsid::identify {
namespace {

using ndsid::testing::kWheelbase;
using ndsid::testing::Pointers;
using ndsid::testing::SyntheticTwoOutputSegments;
using ndsid::testing::TruthParams;

constexpr double kDeg = M_PI / 180.0;
constexpr double kNoiseA = 0.05;          // m/s^2
constexpr double kNoiseR = 0.1 * kDeg;    // rad/s

config::IdentificationConfig TwoOutputs() {
  config::IdentificationConfig c = ndsid::testing::DefaultIdentificationConfig();
  c.yaw_rate_output = true;
  return c;
}

// Drives with the given gyro offsets [deg/s] (drive ids first_id, first_id + 1, ...), each of
// `segments` one-minute segments of the exact model with that offset on the measured yaw rate.
std::vector<stats::Segment> Drives(const std::vector<double>& offsets_degps, int segments, uint64_t seed, int64_t first_id = 0) {
  const model::ModelSpec truth_spec = model::ModelSpec::FromNames({"gyro_offset"});
  const auto p = TruthParams();
  std::vector<stats::Segment> out;
  for (size_t d = 0; d < offsets_degps.size(); ++d) {
    const std::vector<double> truth = {p.m, p.Jz, p.cv, p.ch, p.lv, p.is, offsets_degps[d] * kDeg};
    for (auto& s : SyntheticTwoOutputSegments(truth_spec, truth, segments, 60, kNoiseA, kNoiseR, seed + 17 * d)) {
      s.drive_id = first_id + static_cast<int64_t>(d);
      out.push_back(std::move(s));
    }
  }
  return out;
}

// Catches: per-drive values not estimated or assigned to the wrong drive, the reference drive's
// value not being the parameter vector's, a held-out drive predicted without its own value, or
// EG pulled by offsets that differ between drives.
TEST(PerDrive, GyroOffsetOfEveryDriveAndEgForThreeSeeds) {
  const std::vector<double> offsets = {0.3, -0.2, 0.5, 0.0};  // deg/s, training drives 0..3
  const double held_out_offset = 0.15;                          // drive 10
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);
  for (uint64_t seed : {41u, 42u, 43u}) {
    const auto train = Drives(offsets, 4, seed);
    const auto valid = Drives({held_out_offset}, 3, seed + 500, 10);
    const Identifier per_drive(TwoOutputs(), kWheelbase, model::ModelSpec::FromNames({"gyro_offset_per_drive"}));
    const Identifier global(TwoOutputs(), kWheelbase, model::ModelSpec::FromNames({"gyro_offset"}));
    const IdentificationResult fit = per_drive.Identify(Pointers(train), Pointers(valid));
    const IdentificationResult one = global.Identify(Pointers(train), Pointers(valid));
    ASSERT_TRUE(fit.valid) << fit.reason;
    ASSERT_TRUE(one.valid) << one.reason;
    ASSERT_EQ(fit.drive_values.size(), offsets.size() + 1);
    for (const DriveValue& v : fit.drive_values) {
      const double truth = v.drive_id == 10 ? held_out_offset : offsets[static_cast<size_t>(v.drive_id)];
      std::printf("seed %llu drive %lld: %s %.4f ± %.4f deg/s (truth %.2f)%s%s\n", static_cast<unsigned long long>(seed),
                  static_cast<long long>(v.drive_id), v.param.c_str(), v.value / kDeg, v.se / kDeg, truth,
                  v.reference ? " reference" : "", v.validation ? " held out" : "");
      EXPECT_EQ(v.param, "gyro_offset_radps");
      EXPECT_NEAR(v.value / kDeg, truth, 0.02) << "drive " << v.drive_id;  // se about 0.002 deg/s
      EXPECT_GT(v.se, 0.0);
      EXPECT_EQ(v.reference, v.drive_id == 0);
      EXPECT_EQ(v.validation, v.drive_id == 10);
    }
    // The vector's entry is the reference drive's offset.
    ASSERT_EQ(fit.effect_params.size(), 1u);
    EXPECT_NEAR(fit.effect_params[0].value / kDeg, offsets[0], 0.02);
    EXPECT_FALSE(fit.effect_params[0].fixed);
    std::printf("seed %llu: EG per drive %+.3f %%, one offset %+.3f %%; yaw RMSE train %.4f vs %.4f, held-out %.4f vs %.4f deg/s\n",
                static_cast<unsigned long long>(seed), 100 * (fit.eg_rad_per_mps2 / eg_true - 1),
                100 * (one.eg_rad_per_mps2 / eg_true - 1), fit.rmse_train_yaw_radps / kDeg, one.rmse_train_yaw_radps / kDeg,
                fit.rmse_validation_yaw_radps / kDeg, one.rmse_validation_yaw_radps / kDeg);
    EXPECT_NEAR(fit.eg_rad_per_mps2, eg_true, 0.01 * eg_true);
    // At the noise with an offset per drive; one offset leaves the spread (sd 0.26 deg/s).
    EXPECT_LT(fit.rmse_train_yaw_radps, 1.05 * kNoiseR);
    EXPECT_GT(one.rmse_train_yaw_radps, 2.0 * kNoiseR);
    EXPECT_LT(fit.rmse_validation_yaw_radps, 1.05 * kNoiseR);  // the held-out drive's own offset
    // Counted honestly: the 5 free base parameters, the reference's offset and 3 other drives'.
    EXPECT_EQ(fit.NumEstimated(), one.NumEstimated() + 3);
  }
}

// Catches: a per-drive candidate that scores the common value too (it would outrank the global
// offset on a gyro that is merely offset), or one blind to offsets that differ between drives.
TEST(PerDrive, DiagnosisScoresOnlyTheSpreadBetweenDrives) {
  const Identifier base(TwoOutputs(), kWheelbase);
  auto rank_of = [](const discover::Diagnosis& d, const std::string& effect) {
    for (size_t i = 0; i < d.ranked.size(); ++i)
      if (d.ranked[i].effect == effect) return std::make_pair(static_cast<int>(i), d.ranked[i]);
    return std::make_pair(-1, discover::CandidateScore{});
  };
  {  // one offset for every drive: the global form, not the per-drive one
    const auto train = Drives({0.4, 0.4, 0.4, 0.4}, 4, 51);
    const auto fit = base.Identify(Pointers(train), {});
    ASSERT_TRUE(fit.valid);
    const discover::Diagnosis d = discover::Diagnose(base, fit.AllValues(), Pointers(train));
    const auto [rg, g] = rank_of(d, "gyro_offset");
    const auto [rp, p] = rank_of(d, "gyro_offset_per_drive");
    std::printf("one offset: gyro_offset rank %d z %.1f; per drive rank %d z %.1f dRSS %.3g\n", rg, g.z_robust, rp, p.z_robust, p.drss);
    EXPECT_EQ(rg, 0);
    EXPECT_TRUE(g.significant);
    ASSERT_GE(rp, 0);
    EXPECT_FALSE(p.significant);
  }
  {  // offsets that differ: with gyro_offset in the model, the per-drive form is what is left
    const auto train = Drives({0.3, -0.2, 0.5, 0.0}, 4, 52);
    const Identifier with(TwoOutputs(), kWheelbase, model::ModelSpec::FromNames({"gyro_offset"}));
    const auto fit = with.Identify(Pointers(train), {});
    ASSERT_TRUE(fit.valid);
    const discover::Diagnosis d = discover::Diagnose(with, fit.AllValues(), Pointers(train));
    const auto [rp, p] = rank_of(d, "gyro_offset_per_drive");
    std::printf("offsets differ: per drive rank %d z %.1f, spread %.3f deg/s\n", rp, p.z_robust, p.one_step / kDeg);
    EXPECT_EQ(rp, 0);
    EXPECT_TRUE(p.significant);
    EXPECT_NEAR(p.one_step / kDeg, 0.30, 0.05);  // sd of {0.3, -0.2, 0.5, 0.0} = 0.303
  }
}

// Catches: a ladder that cannot move from a global to a per-drive parameter (both in one model
// would be the same column twice), or that keeps the global form when the offsets differ.
TEST(PerDrive, LadderReplacesTheGlobalOffsetByThePerDriveOne) {
  const auto train = Drives({0.3, -0.2, 0.5, 0.0, 0.25}, 3, 61);
  const auto valid = Drives({0.1, 0.35}, 3, 62, 20);
  discover::LadderOptions options;
  options.align = false;
  const discover::Ladder ladder =
      discover::ClimbErrorLadder(TwoOutputs(), kWheelbase, {"gyro_offset"}, model::EffectLibrary::Builtin(), Pointers(train), Pointers(valid), options);
  for (const auto& r : ladder.rungs) std::printf("rung %-45s + %s\n", r.model.c_str(), r.added.c_str());
  std::vector<std::string> effects;  // the final model's effects, from "single-track + a + b"
  const std::string& m = ladder.rungs.back().model;
  for (size_t at = m.find(" + "); at != std::string::npos; at = m.find(" + ", at + 3)) {
    const size_t end = m.find(" + ", at + 3);
    effects.push_back(m.substr(at + 3, end == std::string::npos ? std::string::npos : end - at - 3));
  }
  EXPECT_NE(std::find(effects.begin(), effects.end(), "gyro_offset_per_drive"), effects.end()) << m;
  EXPECT_EQ(std::find(effects.begin(), effects.end(), "gyro_offset"), effects.end()) << m;
  const double eg_true = model::SelfSteerGradient(TruthParams(), kWheelbase);
  EXPECT_NEAR(ladder.rungs.back().fit.eg_rad_per_mps2, eg_true, 0.01 * eg_true);
}

// Catches: alternatives combined into one model (the same column twice, singular).
TEST(PerDrive, AModelHoldsOneFormOfAParameter) {
  EXPECT_THROW(model::ModelSpec::FromNames({"gyro_offset", "gyro_offset_per_drive"}), ConfigError);
  const model::ModelSpec spec = model::ModelSpec::FromNames({"road_bank", "gyro_offset_per_drive", "load_change"});
  ASSERT_EQ(spec.per_drive_params().size(), 2u);
  EXPECT_EQ(spec.param_name(spec.per_drive_params()[0]), "load_ratio");
  EXPECT_EQ(spec.param_name(spec.per_drive_params()[1]), "gyro_offset_radps");
}

// Catches: per-drive values lost in the one codec, or results written before per-drive
// parameters were generic ("drive_loads" of load_change) no longer read; the halves' in_time flag
// kept, and false where an older result lacks it.
TEST(PerDrive, ValuesSurviveTheCodecAndOldLoadsMigrate) {
  IdentificationResult r;
  r.model = "single-track + road_bank + load_change";
  r.effect_params.push_back({"road_bank_gain", "-", 1.0, 0.01, false, false});
  r.effect_params.push_back({"load_ratio", "-", 1.0, 0.0, true, false});
  r.drive_values = {{3, "load_ratio", 1.0, 0.0, true, false}, {5, "load_ratio", 1.137, 0.002, false, false},
                    {9, "load_ratio", 0.981, 0.004, false, true}};
  HalfEstimate later;
  later.in_time = true;  // a single drive's halves in time
  r.halves = std::make_pair(later, later);
  const nlohmann::json j = ResultToJson(r);
  const IdentificationResult back = ResultFromJson(JsonIn(j, "fit"));
  ASSERT_TRUE(back.halves);
  EXPECT_TRUE(back.halves->first.in_time && back.halves->second.in_time);
  ASSERT_EQ(back.drive_values.size(), 3u);
  for (size_t i = 0; i < 3; ++i) {
    EXPECT_EQ(back.drive_values[i].drive_id, r.drive_values[i].drive_id);
    EXPECT_EQ(back.drive_values[i].param, "load_ratio");
    EXPECT_EQ(back.drive_values[i].value, r.drive_values[i].value);
    EXPECT_EQ(back.drive_values[i].se, r.drive_values[i].se);
    EXPECT_EQ(back.drive_values[i].reference, r.drive_values[i].reference);
    EXPECT_EQ(back.drive_values[i].validation, r.drive_values[i].validation);
  }
  // As written before: no "drive_values", the ratios under "drive_loads".
  nlohmann::json old = j;
  old.erase("drive_values");
  for (auto& h : old["halves"]) h.erase("in_time");  // halves as written before: alternate drives
  old["drive_loads"] = nlohmann::json::array({{{"drive", 3}, {"ratio", 1.0}, {"se", 0.0}, {"reference", true}, {"held_out", false}},
                                              {{"drive", 5}, {"ratio", 1.137}, {"se", 0.002}, {"reference", false}, {"held_out", false}}});
  const IdentificationResult migrated = ResultFromJson(JsonIn(old, "fit"));
  ASSERT_TRUE(migrated.halves);
  EXPECT_FALSE(migrated.halves->first.in_time);
  ASSERT_EQ(migrated.drive_values.size(), 2u);
  EXPECT_EQ(migrated.drive_values[1].param, "load_ratio");
  EXPECT_EQ(migrated.drive_values[1].value, 1.137);
  EXPECT_TRUE(migrated.drive_values[0].reference);
  // An older fit of a load model had no load_ratio entry: laid out for today's model it gets
  // the neutral value, so its vector is never short.
  IdentificationResult older = migrated;
  older.effect_params.pop_back();
  const model::ModelSpec spec = model::ModelSpec::FromNames({"road_bank", "load_change"});
  const std::vector<double> v = older.ValuesFor(spec);
  ASSERT_EQ(static_cast<int>(v.size()), spec.num_params());
  EXPECT_EQ(v[static_cast<size_t>(spec.param_index("load_ratio"))], 1.0);
  EXPECT_EQ(v[static_cast<size_t>(spec.param_index("road_bank_gain"))], 1.0);
}

}  // namespace
}  // namespace ndsid::identify
