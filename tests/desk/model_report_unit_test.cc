// The pieces of `ndsid compare` / `ndsid diagnose` that need no replay: the config edit of
// --apply, the failing-bin rule, the CLI's errors, and the model fix they depend on.
#include <gtest/gtest.h>
#include <sys/wait.h>

#include <cmath>
#include <cstdio>
#include <filesystem>
#include <fstream>

#include "config_edit.h"
#include "model_report.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/model/simulate.h"

namespace ndsid::desk {
namespace {
namespace fs = std::filesystem;

std::string Pristine() { return ReadWholeFile(NDSID_APP_PRISTINE); }

// Lines of a that differ from b (same line count expected).
std::vector<std::string> ChangedLines(const std::string& a, const std::string& b) {
  std::stringstream sa(a), sb(b);
  std::vector<std::string> out;
  std::string la, lb;
  while (std::getline(sa, la)) {
    if (!std::getline(sb, lb) || la != lb) out.push_back(la);
  }
  return out;
}

// Catches: diagnose --apply losing a role's other keys or comment, or writing a latency the
// configuration does not read back.
TEST(SetRoleLatencies, WritesFlowAndBlockMappingsAndReplacesAnOldValue) {
  const std::string text = ReadWholeFile(NDSID_APP_PRISTINE);
  std::string what;
  const std::string after = SetRoleLatencies(text, {{config::Role::kSteeringWheelAngle, 0.0625}}, NDSID_APP_PRISTINE, &what);
  std::printf("%s\n", what.c_str());
  const config::Config c = config::ParseConfig(after, NDSID_APP_PRISTINE);
  EXPECT_NEAR(c.role(config::Role::kSteeringWheelAngle)->latency_s, 0.0625, 6e-4);
  EXPECT_EQ(c.role(config::Role::kSteeringWheelAngle)->ref.signal, config::ParseConfig(text, NDSID_APP_PRISTINE).role(config::Role::kSteeringWheelAngle)->ref.signal);
  // Applied again (data already aligned, the total written), the old value is replaced.
  const std::string again = SetRoleLatencies(after, {{config::Role::kSteeringWheelAngle, 0.07}}, NDSID_APP_PRISTINE, nullptr);
  EXPECT_EQ(std::count(again.begin(), again.end(), '\n'), std::count(text.begin(), text.end(), '\n'));
  EXPECT_NEAR(config::ParseConfig(again, NDSID_APP_PRISTINE).role(config::Role::kSteeringWheelAngle)->latency_s, 0.07, 6e-4);
  // Block mapping.
  const std::string block = std::string(R"(vehicle: {name: t, wheelbase_m: 2.648, mass_kg: 1900}
source: {type: log, logs: [x.log]}
dbc: x.dbc
signals:
  steering_wheel_angle:
    message: A
    signal: B
    unit: deg  # sensor
  vehicle_speed: {message: A, signal: C, unit: km/h}
  lateral_acceleration: {message: A, signal: D, unit: m/s^2}
)");
  const std::string b2 = SetRoleLatencies(block, {{config::Role::kSteeringWheelAngle, 0.05}, {config::Role::kSpeed, -0.01}}, "b.yaml", nullptr);
  const config::Config cb = config::ParseConfig(b2, "b.yaml");
  EXPECT_NEAR(cb.role(config::Role::kSteeringWheelAngle)->latency_s, 0.05, 6e-4);
  EXPECT_NEAR(cb.role(config::Role::kSpeed)->latency_s, -0.01, 6e-4);
  EXPECT_THROW(SetRoleLatencies(block, {{config::Role::kYawRate, 0.05}}, "b.yaml", nullptr), ConfigError);
}

TEST(SetModelEffects, ReplacesFlowListKeepingEveryOtherLineAndTheComment) {
  const std::string before = Pristine();
  std::string what;
  const std::string after = SetModelEffects(before, {"steer_offset", "roll"}, NDSID_APP_PRISTINE, &what);
  const auto changed = ChangedLines(after, before);
  ASSERT_EQ(changed.size(), 1u) << after;
  EXPECT_NE(changed[0].find("effects: [steer_offset, roll]"), std::string::npos) << changed[0];
  EXPECT_NE(changed[0].find("# effects added to the base single-track model"), std::string::npos) << changed[0];
  EXPECT_EQ(config::ParseConfig(after, NDSID_APP_PRISTINE).model_effects, (std::vector<std::string>{"steer_offset", "roll"}));
  EXPECT_NE(what.find("[] -> [steer_offset, roll]"), std::string::npos) << what;
}

TEST(SetModelEffects, ReplacesBlockSequenceUnderModel) {
  std::string text = Pristine();
  const size_t at = text.find("  effects: []");
  ASSERT_NE(at, std::string::npos);
  text.replace(at, std::string("  effects: []").size(), "  effects:\n    - accel_bias   # a comment\n    - roll");
  ASSERT_EQ(config::ParseConfig(text, NDSID_APP_PRISTINE).model_effects, (std::vector<std::string>{"accel_bias", "roll"}));
  std::string what;
  const std::string after = SetModelEffects(text, {"steer_offset"}, NDSID_APP_PRISTINE, &what);
  EXPECT_EQ(config::ParseConfig(after, NDSID_APP_PRISTINE).model_effects, std::vector<std::string>{"steer_offset"});
  EXPECT_EQ(after.find("- roll"), std::string::npos);
  EXPECT_NE(what.find("[accel_bias, roll] -> [steer_offset]"), std::string::npos) << what;
}

TEST(SetModelEffects, AddsModelSectionWhenMissing) {
  std::string text = Pristine();
  const size_t a = text.find("\nmodel:");
  const size_t b = text.find("\nstate_dir:");
  ASSERT_TRUE(a != std::string::npos && b != std::string::npos && a < b);
  text.erase(a, b - a);
  ASSERT_TRUE(config::ParseConfig(text, NDSID_APP_PRISTINE).model_effects.empty());
  std::string what;
  const std::string after = SetModelEffects(text, {"steer_offset"}, NDSID_APP_PRISTINE, &what);
  EXPECT_EQ(config::ParseConfig(after, NDSID_APP_PRISTINE).model_effects, std::vector<std::string>{"steer_offset"});
  EXPECT_EQ(after.substr(0, text.size()), text);  // appended, nothing before it touched
  EXPECT_NE(what.find("added the model section"), std::string::npos);
}

TEST(SetModelEffects, RewritesOneLineModelMap) {
  std::string text = Pristine();
  const size_t a = text.find("\nmodel:");
  const size_t b = text.find("\nstate_dir:");
  text.replace(a, b - a, "\nmodel: {effects: [roll]}\n");
  const std::string after = SetModelEffects(text, {"steer_offset", "accel_bias"}, NDSID_APP_PRISTINE, nullptr);
  EXPECT_EQ(config::ParseConfig(after, NDSID_APP_PRISTINE).model_effects,
            (std::vector<std::string>{"steer_offset", "accel_bias"}));
}

// Catches: --apply's model.alternatives written over model.effects, or lost on a second edit.
TEST(SetModelList, AddsAndReplacesAlternativesBesideTheEffects) {
  const std::string before = SetModelEffects(Pristine(), {"steer_offset"}, NDSID_APP_PRISTINE, nullptr);
  std::string what;
  const std::string added = SetModelList(before, "alternatives", {"lever_arm", "roll"}, NDSID_APP_PRISTINE, &what);
  const config::Config a = config::ParseConfig(added, NDSID_APP_PRISTINE);
  EXPECT_EQ(a.model_effects, std::vector<std::string>{"steer_offset"});
  EXPECT_EQ(a.model_alternatives, (std::vector<std::string>{"lever_arm", "roll"}));
  EXPECT_NE(what.find("model.alternatives: [] -> [lever_arm, roll]"), std::string::npos) << what;
  const std::string replaced = SetModelList(added, "alternatives", {}, NDSID_APP_PRISTINE, &what);
  EXPECT_TRUE(config::ParseConfig(replaced, NDSID_APP_PRISTINE).model_alternatives.empty()) << replaced;
  EXPECT_EQ(config::ParseConfig(replaced, NDSID_APP_PRISTINE).model_effects, std::vector<std::string>{"steer_offset"});
  EXPECT_EQ(ChangedLines(replaced, added).size(), 1u);
  std::string one_line = Pristine();
  const size_t s = one_line.find("\nmodel:"), e = one_line.find("\nstate_dir:");
  one_line.replace(s, e - s, "\nmodel: {effects: [roll]}\n");
  EXPECT_THROW(SetModelList(one_line, "alternatives", {"lever_arm"}, NDSID_APP_PRISTINE, nullptr), ConfigError);
}

// --- the failing-bin rule ---------------------------------------------------------------------
TEST(ComputeBin, FlagsBiasLargerThanClusteredErrorAndHalfNoiseFloor) {
  std::vector<double> e;
  std::vector<int> cl;
  for (int c = 0; c < 10; ++c)
    for (int k = 0; k < 100; ++k) e.push_back(-0.1 + 0.01 * ((k % 3) - 1)), cl.push_back(c);
  const BinStats b = ComputeBin(e, cl, 0.05, 0.2);
  EXPECT_EQ(b.verdict, BinVerdict::kFailBias);
  EXPECT_NEAR(b.bias, -0.1, 1e-3);
  EXPECT_EQ(b.clusters, 10);
}

TEST(ComputeBin, DoesNotFlagBiasThatChunksDisagreeOn) {
  // Mean -0.02, but the chunks scatter by ±0.2 (a slowly varying road): not significant.
  std::vector<double> e;
  std::vector<int> cl;
  for (int c = 0; c < 10; ++c)
    for (int k = 0; k < 100; ++k) e.push_back(-0.02 + (c % 2 ? 0.2 : -0.2)), cl.push_back(c);
  const BinStats b = ComputeBin(e, cl, 0.05, 0.25);
  EXPECT_EQ(b.verdict, BinVerdict::kOk) << b.bias << " ± " << b.se;
}

TEST(ComputeBin, DoesNotFlagSignificantBiasBelowHalfTheNoiseFloor) {
  std::vector<double> e(1000, 0.01);
  std::vector<int> cl(1000);
  for (int i = 0; i < 1000; ++i) cl[i] = i / 100, e[i] += 1e-3 * (i % 7);
  EXPECT_EQ(ComputeBin(e, cl, 0.05, 0.1).verdict, BinVerdict::kOk);
}

TEST(ComputeBin, FlagsRmseAboveFactorOfOverall) {
  std::vector<double> e;
  std::vector<int> cl;
  for (int i = 0; i < 1000; ++i) e.push_back(i % 2 ? 0.2 : -0.2), cl.push_back(i / 100);
  EXPECT_EQ(ComputeBin(e, cl, 0.05, 0.1).verdict, BinVerdict::kFailRmse);
  EXPECT_EQ(ComputeBin(e, cl, 0.05, 0.15).verdict, BinVerdict::kOk);
}

TEST(ComputeBin, LeavesBinsWithFewSamplesUnjudged) {
  std::vector<double> e(kMinBinSamples - 1, 1.0);
  std::vector<int> cl(e.size(), 0);
  EXPECT_EQ(ComputeBin(e, cl, 0.05, 0.1).verdict, BinVerdict::kTooFew);
}

// --- the library fix the diagnosis depends on ---------------------------------------------------
// steer_delay used to overwrite the steering input, discarding steer_offset applied before it:
// in the diagnosis' all-candidates model steer_offset then had a zero sensitivity and ranked last.
TEST(SteerDelay, KeepsTheSteerOffsetOfAnEarlierEffect) {
  const model::ModelSpec with_delay = model::ModelSpec::FromNames({"steer_offset", "steer_delay"});
  const model::ModelSpec offset_only = model::ModelSpec::FromNames({"steer_offset"});
  std::vector<float> steer(500), speed(500, 25.0f);
  for (size_t k = 0; k < steer.size(); ++k) steer[k] = 0.05f * static_cast<float>(std::sin(0.01 * k));
  const model::InputSeries in{steer.data(), speed.data(), 1, steer.size(), 0.02};
  const std::vector<double> p1 = {1900, 2700, 75000, 120000, 1.15, 14.8, 0.02, 0.0};
  const std::vector<double> p2 = {1900, 2700, 75000, 120000, 1.15, 14.8, 0.02};
  std::vector<double> a1(steer.size()), a2(steer.size());
  model::SimulateModel(with_delay, p1.data(), 2.648, in, a1.data());
  model::SimulateModel(offset_only, p2.data(), 2.648, in, a2.data());
  for (size_t k = 0; k < a1.size(); k += 50) EXPECT_NEAR(a1[k], a2[k], 1e-9) << k;
}

// --- command-line errors ------------------------------------------------------------------------
struct CliRun {
  int code;
  std::string output;
};
CliRun RunNdsid(const std::string& args, const std::string& env = "") {
  const std::string cmd = env + " '" + std::string(NDSID_NDSID_EXE) + "' " + args + " 2>&1";
  CliRun r{-1, ""};
  FILE* p = popen(cmd.c_str(), "r");
  char buf[4096];
  while (size_t n = fread(buf, 1, sizeof buf, p)) r.output.append(buf, n);
  const int status = pclose(p);
  r.code = WIFEXITED(status) ? WEXITSTATUS(status) : -1;
  return r;
}

TEST(CompareCli, UnknownEffectExits78NamingItAndTheKnownOnes) {
  const CliRun r = RunNdsid("compare --config " NDSID_APP_PRISTINE " --effects steer_ofset --out /tmp/unused");
  EXPECT_EQ(r.code, kExitConfig) << r.output;
  EXPECT_NE(r.output.find("unknown effect 'steer_ofset'"), std::string::npos) << r.output;
  EXPECT_NE(r.output.find("steer_offset"), std::string::npos) << r.output;
}

TEST(DiagnoseCli, UnknownCandidateExits78) {
  const CliRun r = RunNdsid("diagnose --config " NDSID_APP_PRISTINE " --candidates roll,wind --out /tmp/unused");
  EXPECT_EQ(r.code, kExitConfig) << r.output;
  EXPECT_NE(r.output.find("unknown effect 'wind'"), std::string::npos) << r.output;
}

TEST(DiagnoseCli, MissingLogExits78NamingTheFile) {
  const CliRun r = RunNdsid("diagnose --config " NDSID_APP_PRISTINE " --log /nonexistent/drive.log.gz --out /tmp/unused");
  EXPECT_EQ(r.code, kExitConfig) << r.output;
  EXPECT_NE(r.output.find("log file not found: /nonexistent/drive.log.gz"), std::string::npos) << r.output;
}

TEST(CompareCli, MissingConfigExits78) {
  const CliRun r = RunNdsid("compare --config /nonexistent/vehicle.yaml");
  EXPECT_EQ(r.code, kExitConfig) << r.output;
}

TEST(CompareCli, HeldOutDriveNotInWindowExits78ListingTheDrives) {
  const CliRun r = RunNdsid("compare --config " NDSID_APP_PRISTINE " --hold-out 7 --out /tmp/unused");
  EXPECT_EQ(r.code, kExitConfig) << r.output;
  EXPECT_NE(r.output.find("drive 7 is not in the window (drives: 0, 2)"), std::string::npos) << r.output;
}

TEST(CompareCli, WritesReportWithoutPlotsAndSaysSoWhenPythonIsMissing) {
  const fs::path out = fs::path(NDSID_APP_OUT) / "compare_nopython";
  fs::remove_all(out);
  const CliRun r = RunNdsid("compare --config " NDSID_APP_PRISTINE " --out " + out.string(), "NDSID_PYTHON=/nonexistent/python3");
  ASSERT_EQ(r.code, 0) << r.output;
  EXPECT_NE(r.output.find("plots not written: Python not found at /nonexistent/python3"), std::string::npos) << r.output;
  const std::string html = ReadWholeFile((out / "report.html").string());
  EXPECT_NE(html.find("No plots:</b> Python not found"), std::string::npos);
  EXPECT_NE(html.find("Where it fails"), std::string::npos);
  EXPECT_FALSE(fs::exists(out / "timeseries.png"));
  EXPECT_TRUE(fs::exists(out / "compare.csv"));
}


// The signed view on rows made with a known gain error per speed band: a_y,meas = (1 + k(v))
// a_y,model + white noise, 40 chunks of 400 samples per band. Catches a gain with the wrong sign
// or scale, a standard error that ignores the noise, and a speed dependence reported where the
// gain is one and the same.
std::vector<SampleRow> RowsWithGains(const std::vector<double>& band_gain, uint32_t seed) {
  std::vector<SampleRow> rows;
  uint32_t x = seed;
  auto uniform = [&x] {  // xorshift32 in (0, 1)
    x ^= x << 13, x ^= x >> 17, x ^= x << 5;
    return (x + 0.5) / 4294967296.0;
  };
  int chunk = 0;
  for (size_t b = 0; b < band_gain.size(); ++b) {
    for (int c = 0; c < 40; ++c, ++chunk) {
      for (int k = 0; k < 400; ++k) {
        SampleRow r{};
        r.scored = true;
        r.chunk = chunk;
        r.speed_mps = 5.0 * static_cast<double>(b) + 2.5;
        const double model = 3.0 * std::sin(0.02 * k + c);
        const double noise = 0.05 * std::sqrt(-2 * std::log(uniform())) * std::cos(2 * M_PI * uniform());
        r.ay_model = {model};
        r.ay_mps2 = (1.0 + band_gain[b]) * model + noise;
        r.yaw_model = {NAN};
        r.yaw_rate_radps = NAN;
        rows.push_back(r);
      }
    }
  }
  return rows;
}

TEST(GainView, RecoversEachBandsSignedGainAndItsSpeedDependence) {
  const std::vector<double> gains = {0.0, 0.0, 0.017, 0.0, -0.03, 0.0, -0.084};
  const GainView v = ComputeGainView(RowsWithGains(gains, 7), 1, false);
  ASSERT_EQ(v.per_model.size(), 1u);
  for (size_t b = 0; b < gains.size(); ++b) {
    const GainBand& g = v.per_model[0][b];
    ASSERT_TRUE(g.judged) << g.label;
    EXPECT_NEAR(g.gain, gains[b], 4 * g.se) << g.label;
    EXPECT_LT(g.se, 0.002) << g.label;
    EXPECT_EQ(g.flagged, gains[b] != 0.0) << g.label;
  }
  EXPECT_TRUE(v.speed_dependent[0]);
}

TEST(GainView, OneGainAtEverySpeedIsFlaggedButNotSpeedDependent) {
  const GainView v = ComputeGainView(RowsWithGains(std::vector<double>(6, 0.03), 11), 1, false);
  for (const GainBand& g : v.per_model[0]) {
    if (!g.judged) continue;
    EXPECT_TRUE(g.flagged) << g.label;
    EXPECT_NEAR(g.gain, 0.03, 4 * g.se) << g.label;
  }
  EXPECT_FALSE(v.speed_dependent[0]);
  EXPECT_EQ(v.dof[0], 5);
}

}  // namespace
}  // namespace ndsid::desk
