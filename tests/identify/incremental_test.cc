// Incremental re-identification (docs/incremental.md) against its reference, the full-window
// fit at the same warm start, at every periodic update of simulated naturalistic driving
// (the project's simulator through the gate and the window, as the daemon sees it), and
// against the simulator's truth. Seeds, outputs and effects are varied.
#include <gtest/gtest.h>
#include <spdlog/spdlog.h>

#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <functional>
#include <regex>
#include <string>
#include <vector>

#include "ndsid/common/error.h"
#include "ndsid/config/config.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/gate/gate.h"
#include "ndsid/identify/chunks.h"
#include "ndsid/identify/identifier.h"
#include "ndsid/identify/linearized_window.h"
#include "ndsid/sim/simulator.h"
#include "ndsid/stats/accumulator.h"

namespace ndsid::identify {
namespace {

struct SimRun {
  config::Config cfg;
  config::SimulationConfig sim;
  std::vector<std::string> effects;
};

SimRun MakeRun(uint64_t seed, double hours) {
  SimRun run;
  run.cfg = config::LoadConfig(std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml");
  run.sim.seed = seed;
  run.sim.duration.hours = hours;
  return run;
}

// Streams the simulated drives through the gate into the window and calls `update` every
// period_s of data time once the window has grown since the last call, and once at the end.
void Grow(const SimRun& run, const std::function<void(const stats::Accumulator&)>& update) {
  gate::Gate gate(run.cfg.gate, 0.01);
  stats::Accumulator acc(run.cfg, 100.0);
  const int64_t period_ns = static_cast<int64_t>(run.cfg.identification.period_s * 1e9);
  int64_t next_ns = 0;
  double last_h = 0;
  auto maybe = [&](int64_t t_ns, bool force) {
    if ((force || t_ns >= next_ns) && acc.gated_hours() > last_h && !acc.window().empty()) {
      update(acc);
      last_h = acc.gated_hours();
      next_ns = t_ns + period_ns;
    }
  };
  sim::SimulateDrives(run.sim, [&](sim::DriveResult&& d) {
    const auto& s = d.series;
    for (size_t i = 0; i < s.t_s.size(); ++i) {
      sync::Sample x;
      x.t_ns = d.start_epoch_ns + static_cast<int64_t>(s.t_s[i] * 1e9);
      x.steer_rad = s.steer_sw_meas_rad[i];
      x.speed_mps = s.speed_meas_mps[i];
      x.lat_accel_mps2 = s.a_y_meas_mps2[i];
      x.yaw_rate_radps = s.yaw_rate_meas_radps[i];
      x.long_accel_mps2 = s.a_x_meas_mps2[i];
      x.has_yaw_rate = x.has_long_accel = true;
      x.reverse = s.reverse[i] != 0;
      x.esc_active = s.esp_active[i] != 0;
      x.valid = s.valid[i] != 0;
      acc.Add(gate.Process(x));
      maybe(x.t_ns, false);
    }
  });
  acc.Finish();
  maybe(0, true);
}

SegmentList Window(const stats::Accumulator& acc) {
  SegmentList segs;
  for (const auto& s : acc.window()) segs.push_back(s.get());
  return segs;
}

double TrueEg(const SimRun& run) {
  const auto& v = run.sim.vehicle;
  const model::Params<double> p{v.mass_kg, v.yaw_inertia_kgm2, v.cornering_stiffness_front_npr,
                                v.cornering_stiffness_rear_npr, v.cg_to_front_m, v.steering_ratio};
  return model::SelfSteerGradient(p, v.wheelbase_m);
}

struct Comparison {
  int updates = 0, incremental = 0;
  size_t simulated = 0, total = 0;  // chunks simulated or relinearised by the incremental path / fitted by the full fits
  double worst_sigma = 0;        // max |EG_inc - EG_full| / sigma_full over the updates
  double worst_se_ratio = 0;     // max |sigma_inc / sigma_full - 1|
  size_t last_simulated = 0, last_total = 0;
  IdentificationResult last_inc, last_full;
};

// At every update: the incremental fit on top of the previous one's linearisation, and the
// full-window fit from the same warm start.
Comparison Compare(const SimRun& run) {
  const Identifier id(run.cfg.identification, run.cfg.vehicle.wheelbase_m, model::ModelSpec::FromNames(run.effects));
  std::shared_ptr<const LinearizedWindow> prior;
  std::optional<std::vector<double>> warm;
  Comparison c;
  Grow(run, [&](const stats::Accumulator& acc) {
    const SegmentList segs = Window(acc);
    IdentificationResult inc = id.Identify(segs, {}, warm, IncrementalUpdate{prior, run.cfg.identification.relinearize_sigma, true});
    const IdentificationResult full = id.Identify(segs, {}, warm);
    ASSERT_TRUE(inc.valid) << inc.reason;
    ASSERT_TRUE(full.valid) << full.reason;
    ++c.updates;
    if (inc.chunks_from_prior > 0) ++c.incremental;
    const double dev = std::abs(inc.eg_rad_per_mps2 - full.eg_rad_per_mps2) / full.eg_se_rad_per_mps2;
    c.worst_sigma = std::max(c.worst_sigma, dev);
    c.worst_se_ratio = std::max(c.worst_se_ratio, std::abs(inc.eg_se_rad_per_mps2 / full.eg_se_rad_per_mps2 - 1));
    std::printf("  %.2f gated h: EG inc %.5e full %.5e (%.3f sigma apart), sigma inc %.3e full %.3e; %s\n",
                acc.gated_hours(), inc.eg_rad_per_mps2, full.eg_rad_per_mps2, dev, inc.eg_se_rad_per_mps2,
                full.eg_se_rad_per_mps2, inc.update.c_str());
    if (std::getenv("NDSID_TEST_VERBOSE")) {
      std::printf("    se: inc %s, full %s\n", inc.se_method.c_str(), full.se_method.c_str());
      const auto a = inc.AllValues(), b = full.AllValues();
      for (size_t i = 0; i < a.size(); ++i) std::printf("    p%zu inc %.6g full %.6g (se inc %.3g full %.3g)\n", i, a[i], b[i],
                                                        i < 6 ? inc.params[i].se : 0.0, i < 6 ? full.params[i].se : 0.0);
    }
    EXPECT_EQ(inc.chunks, full.chunks);
    EXPECT_EQ(inc.residuals_train, full.residuals_train);
    c.simulated += inc.chunks_simulated + inc.chunks_relinearized;  // each relinearisation: one simulation
    c.total += full.chunks;
    c.last_simulated = inc.chunks_simulated;
    c.last_total = inc.chunks;
    prior = inc.linearized;
    warm = inc.AllValues();
    c.last_inc = std::move(inc);
    c.last_full = full;
  });
  return c;
}

// Catches: a prior that double-counts or drops data (EG and sigma move from the reference), a
// wrong sign or transpose in the quadratic, stale linearisation points never refreshed.
// In the first hours the estimate still moves by more than its quadratics allow, and many
// updates simulate most of the window again; later (the long test) almost none do.
TEST(Incremental, FollowsTheFullWindowFitAtEveryUpdateForTwoSeeds) {
  const char* only = std::getenv("NDSID_TEST_SEED");
  if (std::getenv("NDSID_TEST_VERBOSE")) spdlog::set_level(spdlog::level::debug);
  for (uint64_t seed : {3u, 4u}) {
    if (only && std::strtoull(only, nullptr, 10) != seed) continue;
    SimRun run = MakeRun(seed, 1.2);
    run.effects = run.cfg.model_effects;  // the daemon's setup: the example config as it is
    ASSERT_TRUE(run.cfg.identification.yaw_rate_output) << "both outputs (the yaw rate is configured)";
    std::printf("seed %llu\n", static_cast<unsigned long long>(seed));
    const Comparison c = Compare(run);
    std::printf("seed %llu: %d updates, %d on a prior; %zu chunks simulated against %zu by full fits\n",
                static_cast<unsigned long long>(seed), c.updates, c.incremental, c.simulated, c.total);
    EXPECT_GE(c.updates, 4) << seed;
    EXPECT_GE(c.incremental, 1) << seed;
    EXPECT_LE(c.worst_sigma, 0.2) << seed;
    // sigma(EG) of an update is pooled from the prior's stored chunk statistics: with the 9-70
    // chunks of these updates a cluster-robust variance is itself uncertain by sqrt(2/n); the two
    // paths' sigma were measured up to 13 % apart here (the long test allows 15 % too).
    EXPECT_LE(c.worst_se_ratio, 0.15) << seed;
    EXPECT_LT(c.simulated, c.total) << seed;
    // And it is right: the truth within 3 sigma (or 1 %).
    const double eg = TrueEg(run);
    EXPECT_NEAR(c.last_inc.eg_rad_per_mps2, eg, std::max(3 * c.last_inc.eg_se_rad_per_mps2, 0.01 * eg)) << seed;
  }
}

// An exact update (the final fit and the scheduled ones: every prior chunk relinearised at the
// estimate until it stays within 0.05 sigma of their points) is the whole-window fit: at every
// update of two seeds (both outputs, the example's effects), on the incremental chain's prior,
// against the full-window fit from the same warm start.
TEST(Incremental, ExactUpdateIsTheWholeWindowFit) {
  for (uint64_t seed : {3u, 4u}) {
    SimRun run = MakeRun(seed, 1.2);
    run.effects = run.cfg.model_effects;
    const Identifier id(run.cfg.identification, run.cfg.vehicle.wheelbase_m, model::ModelSpec::FromNames(run.effects));
    std::shared_ptr<const LinearizedWindow> prior;
    std::optional<std::vector<double>> warm;
    int exact_on_prior = 0;
    double worst = 0, worst_se = 0;
    Grow(run, [&](const stats::Accumulator& acc) {
      const SegmentList segs = Window(acc);
      const double sigma = run.cfg.identification.relinearize_sigma;
      const IdentificationResult exact = id.Identify(segs, {}, warm, IncrementalUpdate{prior, sigma, true, true});
      const IdentificationResult full = id.Identify(segs, {}, warm);
      ASSERT_TRUE(exact.valid && full.valid) << exact.reason << full.reason;
      if (exact.chunks_from_prior > 0) {
        ++exact_on_prior;
        EXPECT_NE(exact.update.find("(exact)"), std::string::npos) << exact.update;
        // The schedule's count of updates since the last exact one starts again.
        EXPECT_EQ(exact.linearized->updates_since_full, 0);
      }
      const double dev = std::abs(exact.eg_rad_per_mps2 - full.eg_rad_per_mps2) / full.eg_se_rad_per_mps2;
      const double dse = std::abs(exact.eg_se_rad_per_mps2 / full.eg_se_rad_per_mps2 - 1);
      std::printf("  seed %llu, %.2f gated h: exact vs full EG %.4f sigma apart, sigma %.2f %% apart; %s\n",
                  static_cast<unsigned long long>(seed), acc.gated_hours(), dev, 100 * dse, exact.update.c_str());
      worst = std::max(worst, dev);
      worst_se = std::max(worst_se, dse);
      EXPECT_EQ(exact.chunks, full.chunks);
      // The chain goes on as the daemon's: an ordinary incremental update on the prior.
      IdentificationResult inc = id.Identify(segs, {}, warm, IncrementalUpdate{prior, sigma, true});
      ASSERT_TRUE(inc.valid) << inc.reason;
      prior = inc.linearized;
      warm = inc.AllValues();
    });
    EXPECT_GE(exact_on_prior, 4) << seed;
    // Measured at most 0.0106 sigma and 0.34 % apart (the exact update relinearises every chunk
    // at its first solution and stops where its EG check finds the quadratics' error below 0.01
    // sigma; its output weights pool the noise levels at its start, the full fit's are taken at
    // its own solution).
    EXPECT_LE(worst, 0.02) << seed;
    EXPECT_LE(worst_se, 0.01) << seed;
  }
}

// The long target (label long, about 10 min): 10 h of simulated driving, the incremental EG
// within 0.2 sigma of the full-window fit at every update, and the incremental path simulating
// well under the full fits' chunks over the run.
TEST(IncrementalLong, TenHoursFollowTheFullWindowFitAtEveryUpdate) {
  if (std::getenv("NDSID_TEST_VERBOSE")) spdlog::set_level(spdlog::level::debug);
  SimRun run = MakeRun(5, 10.0);
  run.cfg.identification.yaw_rate_output = false;  // the base model on a_y, as measured below
  const Comparison c = Compare(run);
  std::printf("%d updates, %d on a prior; %zu chunks simulated against %zu by full fits; worst %.3f sigma\n", c.updates,
              c.incremental, c.simulated, c.total, c.worst_sigma);
  EXPECT_LE(c.worst_sigma, 0.2);
  // sigma(EG) is pooled from the prior's stored chunk statistics, checked on a sample of them at
  // every update (its bread and cluster-robust meat within 10 %): measured up to 3.0 % apart from
  // the full fit's over the 83 updates of this run; 11.7 % without that check (docs/incremental.md).
  EXPECT_LE(c.worst_se_ratio, 0.06);
  // Measured: 11 708 chunks against 26 349 (44 %); about a quarter of the updates find their
  // prior's quadratics far off and fit the whole window.
  EXPECT_LT(c.simulated, c.total / 2);
  const double eg = TrueEg(run);
  EXPECT_NEAR(c.last_inc.eg_rad_per_mps2, eg, std::max(3 * c.last_inc.eg_se_rad_per_mps2, 0.01 * eg));
}

// Both outputs and two sensor effects at once (a steering offset and a gyro offset, of signs
// that differ from the defaults): the prior carries the effects' parameters and the weights.
TEST(Incremental, TwoOutputsWithSensorEffectsFollowTheFullFit) {
  SimRun run = MakeRun(21, 1.2);
  run.cfg.identification.yaw_rate_output = true;
  run.effects = {"steer_offset", "gyro_offset"};
  run.sim.effects.steer_offset_deg = -1.2;
  run.sim.effects.gyro_offset_degps = 0.35;
  const Comparison c = Compare(run);
  EXPECT_GE(c.incremental, 1);
  EXPECT_LT(c.simulated, c.total);
  EXPECT_LE(c.worst_sigma, 0.2);
  EXPECT_LE(c.worst_se_ratio, 0.10);
  ASSERT_TRUE(c.last_inc.yaw_rate_output);
  const auto find = [&](const char* name) {
    for (const auto& p : c.last_inc.effect_params)
      if (p.name == name) return p;
    ADD_FAILURE() << name;
    return ParameterEstimate{};
  };
  const ParameterEstimate gyro = find("gyro_offset_radps");
  EXPECT_NEAR(gyro.value, 0.35 * M_PI / 180, std::max(4 * gyro.se, 0.02 * M_PI / 180));
  const double eg = TrueEg(run);
  EXPECT_NEAR(c.last_inc.eg_rad_per_mps2, eg, std::max(3 * c.last_inc.eg_se_rad_per_mps2, 0.01 * eg));
  // The identifiability note counts the whole window's chunks, the prior's included, as the full
  // fit does ("N of M chunks have a yaw rate"; it read N > M when M left the prior's out).
  const auto yaw_chunks = [](const IdentificationResult& r) {
    const std::regex re("\\(([0-9]+) of ([0-9]+) chunks have a yaw rate\\)");
    std::smatch m;
    for (const std::string& n : r.identifiability.notes)
      if (std::regex_search(n, m, re)) return std::make_pair(std::stoul(m[1].str()), std::stoul(m[2].str()));
    ADD_FAILURE() << "no yaw-rate note";
    return std::make_pair(0ul, 0ul);
  };
  const auto [inc_yaw, inc_all] = yaw_chunks(c.last_inc);
  const auto [full_yaw, full_all] = yaw_chunks(c.last_full);
  EXPECT_LE(inc_yaw, inc_all);
  EXPECT_EQ(inc_all, c.last_total);
  EXPECT_EQ(inc_yaw, full_yaw);
  EXPECT_EQ(inc_all, full_all);
}

// A prior whose linearisation points lie far from the estimate (every chunk's point moved by
// 10 standard deviations along cv, its quadratic thus wrong there) is not trusted, by either
// guard: every chunk is relinearised at the estimate and the fit equals the full one.
TEST(Incremental, RelinearisesAPriorWhosePointsTheEstimateHasLeft) {
  SimRun run = MakeRun(6, 0.8);
  run.cfg.identification.yaw_rate_output = false;  // a_y alone (both outputs: the test above)
  const Identifier id(run.cfg.identification, run.cfg.vehicle.wheelbase_m);
  SegmentList segs;
  std::vector<std::shared_ptr<const stats::Segment>> keep;
  Grow(run, [&](const stats::Accumulator& acc) {
    keep.assign(acc.window().begin(), acc.window().end());
  });
  for (const auto& s : keep) segs.push_back(s.get());
  const IdentificationResult base = id.Identify(segs, {}, std::nullopt, IncrementalUpdate{nullptr, 0.5, true});
  ASSERT_TRUE(base.valid && base.linearized);
  auto moved = std::make_shared<LinearizedWindow>(*base.linearized);
  const double shift = 10 * base.params[model::kStiffFront].se / moved->scale[model::kStiffFront];
  for (auto& s : moved->segments)
    for (auto& ch : s.chunks) ch.theta[model::kStiffFront] += shift;
  const IdentificationResult inc = id.Identify(segs, {}, base.AllValues(), IncrementalUpdate{moved, 0.5, true});
  ASSERT_TRUE(inc.valid) << inc.reason;
  // Every chunk relinearised in place at the start (no new data to simulate), none left as shifted.
  EXPECT_EQ(inc.chunks_simulated, 0u) << inc.update;
  EXPECT_EQ(inc.chunks_from_prior, base.chunks) << inc.update;
  EXPECT_EQ(inc.chunks_relinearized, base.chunks) << inc.update;
  ASSERT_TRUE(inc.linearized);
  const double cv_base = base.linearized->segments[0].chunks[0].theta[model::kStiffFront];
  for (const auto& s : inc.linearized->segments)
    for (const auto& ch : s.chunks) EXPECT_LT(std::abs(ch.theta[model::kStiffFront] - cv_base), shift / 2);
  EXPECT_NEAR(inc.eg_rad_per_mps2, base.eg_rad_per_mps2, 0.05 * base.eg_se_rad_per_mps2);
  EXPECT_NEAR(inc.eg_se_rad_per_mps2, base.eg_se_rad_per_mps2, 0.05 * base.eg_se_rad_per_mps2);
  // With the distance rule switched off (an infinite threshold), the EG check finds the shifted
  // quadratics (their predicted scores are wrong at the solution) and relinearises them all.
  const IdentificationResult checked = id.Identify(segs, {}, base.AllValues(), IncrementalUpdate{moved, 1e9, true});
  ASSERT_TRUE(checked.valid);
  EXPECT_GE(checked.chunks_relinearized, base.chunks) << checked.update;
  EXPECT_NEAR(checked.eg_rad_per_mps2, base.eg_rad_per_mps2, 0.05 * base.eg_se_rad_per_mps2);
  EXPECT_NEAR(checked.eg_se_rad_per_mps2, base.eg_se_rad_per_mps2, 0.05 * base.eg_se_rad_per_mps2);
}

// A prior built for another model, chunking or outputs is never mixed in: the fit is whole.
TEST(Incremental, APriorOfAnotherModelOrChunkingIsIgnored) {
  SimRun run = MakeRun(7, 0.6);
  run.cfg.identification.yaw_rate_output = false;  // the first prior is built on a_y alone
  std::vector<std::shared_ptr<const stats::Segment>> keep;
  Grow(run, [&](const stats::Accumulator& acc) { keep.assign(acc.window().begin(), acc.window().end()); });
  SegmentList segs;
  for (const auto& s : keep) segs.push_back(s.get());
  const Identifier base(run.cfg.identification, run.cfg.vehicle.wheelbase_m);
  const IdentificationResult b = base.Identify(segs, {}, std::nullopt, IncrementalUpdate{nullptr, 0.5, true});
  ASSERT_TRUE(b.valid && b.linearized);
  const Identifier effect(run.cfg.identification, run.cfg.vehicle.wheelbase_m, model::ModelSpec::FromNames({"steer_offset"}));
  EXPECT_EQ(effect.Identify(segs, {}, std::nullopt, IncrementalUpdate{b.linearized, 0.5, true}).chunks_from_prior, 0u);
  config::IdentificationConfig other = run.cfg.identification;
  other.chunk_s = 45;
  EXPECT_EQ(Identifier(other, run.cfg.vehicle.wheelbase_m).Identify(segs, {}, std::nullopt, IncrementalUpdate{b.linearized, 0.5, true}).chunks_from_prior, 0u);
  other = run.cfg.identification;
  other.yaw_rate_output = true;
  // From the prior's own solution, so no segment is stale by distance and only the outputs can
  // refuse the prior (its a_y-only quadratics hold no yaw-rate residuals, yet the data have a
  // yaw rate: the fit must see that from the data, not from the quadratics).
  const IdentificationResult two =
      Identifier(other, run.cfg.vehicle.wheelbase_m).Identify(segs, {}, b.AllValues(), IncrementalUpdate{b.linearized, 0.5, true});
  EXPECT_EQ(two.chunks_from_prior, 0u) << two.update;
  EXPECT_TRUE(two.yaw_rate_output);
  // The same model: everything comes from the prior, and the estimate stays.
  const IdentificationResult again = base.Identify(segs, {}, b.AllValues(), IncrementalUpdate{b.linearized, 0.5, true});
  EXPECT_EQ(again.chunks_from_prior, b.chunks);
  EXPECT_EQ(again.chunks_simulated, 0u);
  EXPECT_NEAR(again.eg_rad_per_mps2, b.eg_rad_per_mps2, 0.01 * b.eg_se_rad_per_mps2);
  EXPECT_NEAR(again.eg_se_rad_per_mps2, b.eg_se_rad_per_mps2, 0.01 * b.eg_se_rad_per_mps2);
}

// The held-out RMSE of an incremental update comes from the held-out chunks' quadratics
// (LinearizedWindow::held_out) where the estimate stays near their points, and from simulating
// the new or stale ones. At every update it must equal the held-out drives simulated at the
// update's estimate (Identifier::Rmse / RmseYawRate) to 1e-3 of itself (a Gauss-Newton quadratic
// of the sum of squares, from points up to relinearize_sigma away: measured at most 2.9e-4, in
// the first hour, where the estimate still moves most), the quadratics must cover every
// held-out chunk, and most held-out chunks must come from the prior.
// Two seeds, both outputs, every third drive held out; the second seed with a gyro offset
// and a steering offset in the data and in the model.
TEST(Incremental, HeldOutRmseFromTheQuadraticsEqualsTheSimulatedOne) {
  for (const uint64_t seed : {3u, 21u}) {
    SimRun run = MakeRun(seed, 1.2);
    if (seed == 21) {
      config::ApplyEffect(run.sim.effects, "steer_offset_deg=-1.2");
      config::ApplyEffect(run.sim.effects, "gyro_offset_degps=0.35");
      run.effects = {"road_bank", "steer_offset", "gyro_offset"};
    }
    ASSERT_TRUE(run.cfg.identification.yaw_rate_output);
    const Identifier id(run.cfg.identification, run.cfg.vehicle.wheelbase_m, model::ModelSpec::FromNames(run.effects));
    std::shared_ptr<const LinearizedWindow> prior;
    std::optional<std::vector<double>> warm;
    int updates = 0, checked = 0;
    size_t reused = 0, linearized = 0;
    double worst = 0;  // relative error of the held-out RMSE, either output
    Grow(run, [&](const stats::Accumulator& acc) {
      SegmentList train, val;
      for (const auto& seg : acc.window()) (seg->drive_id % 3 == 2 ? val : train).push_back(seg.get());
      if (train.empty()) return;
      const IdentificationResult inc = id.Identify(train, val, warm, IncrementalUpdate{prior, run.cfg.identification.relinearize_sigma, true});
      ASSERT_TRUE(inc.valid) << inc.reason;
      ++updates;
      prior = inc.linearized;
      warm = inc.AllValues();
      if (val.empty()) return;
      size_t na = 0, nr = 0;
      const double a = id.Rmse(inc.AllValues(), val, &na), r = id.RmseYawRate(inc.AllValues(), val, &nr);
      SCOPED_TRACE("seed " + std::to_string(seed) + " at " + std::to_string(acc.gated_hours()) + " gated h");
      EXPECT_EQ(inc.residuals_validation, na);
      EXPECT_NEAR(inc.rmse_validation_mps2, a, 1e-3 * a);
      EXPECT_NEAR(inc.rmse_validation_yaw_radps, r, 1e-3 * r);
      worst = std::max({worst, std::abs(inc.rmse_validation_mps2 / a - 1), std::abs(inc.rmse_validation_yaw_radps / r - 1)});
      size_t held_chunks = 0;
      for (const auto& ls : inc.linearized->held_out) held_chunks += ls.chunks.size();
      EXPECT_EQ(held_chunks, inc.held_out_from_prior + inc.held_out_linearized);
      EXPECT_EQ(held_chunks, MakeChunks(val, run.cfg.identification.chunk_s, run.cfg.identification.burn_in_s).size());
      reused += inc.held_out_from_prior;
      linearized += inc.held_out_linearized;
      ++checked;
    });
    std::printf("  seed %llu: %d updates, %d with held-out drives; held-out chunks %zu from the quadratics, %zu simulated; "
                "worst relative RMSE error %.2e\n", static_cast<unsigned long long>(seed), updates, checked, reused, linearized, worst);
    EXPECT_GE(checked, 4) << "seed " << seed;
    EXPECT_GT(reused, linearized) << "seed " << seed << ": the quadratics should serve most held-out chunks";
  }
}

// The prior is learned state: it survives the codec bit for bit, and a damaged one is refused
// with the path of the bad value.
TEST(Incremental, PriorRoundTripsThroughTheCodecAndRefusesDamage) {
  SimRun run = MakeRun(8, 0.5);
  std::vector<std::shared_ptr<const stats::Segment>> keep;
  Grow(run, [&](const stats::Accumulator& acc) { keep.assign(acc.window().begin(), acc.window().end()); });
  SegmentList segs;
  for (const auto& s : keep) segs.push_back(s.get());
  const Identifier id(run.cfg.identification, run.cfg.vehicle.wheelbase_m);
  const IdentificationResult b = id.Identify(segs, {}, std::nullopt, IncrementalUpdate{nullptr, 0.5, true});
  ASSERT_TRUE(b.valid && b.linearized);
  const nlohmann::json doc = ParseCbor(ToCbor(b.linearized->ToJson()), "test");
  const LinearizedWindow back = LinearizedWindow::FromJson(JsonIn(doc, "linearized"));
  ASSERT_EQ(back.chunks(), b.linearized->chunks());
  {  // The held-out drives' quadratics (the last segment held out here) round-trip too.
    const SegmentList train(segs.begin(), segs.end() - 1), val(segs.end() - 1, segs.end());
    const IdentificationResult h = id.Identify(train, val, b.AllValues(), IncrementalUpdate{nullptr, 0.5, true});
    ASSERT_TRUE(h.valid && h.linearized && !h.linearized->held_out.empty());
    const nlohmann::json hdoc = ParseCbor(ToCbor(h.linearized->ToJson()), "test");
    const LinearizedWindow hback = LinearizedWindow::FromJson(JsonIn(hdoc, "linearized"));
    ASSERT_EQ(hback.held_out.size(), h.linearized->held_out.size());
    EXPECT_EQ(hback.held_out[0].chunks[0].jtj, h.linearized->held_out[0].chunks[0].jtj);
    EXPECT_EQ(hback.held_out[0].chunks[0].score_yaw_rate, h.linearized->held_out[0].chunks[0].score_yaw_rate);
    EXPECT_EQ(hback.held_out[0].chunks[0].rss_a_y, h.linearized->held_out[0].chunks[0].rss_a_y);
    EXPECT_TRUE(hback.held_out[0].chunks[0].acf_a_y.empty());
    // Taken from the prior read back, the held-out RMSE is the simulated one at the new estimate.
    const IdentificationResult again = id.Identify(train, val, h.AllValues(), IncrementalUpdate{std::make_shared<LinearizedWindow>(hback), 0.5, true});
    EXPECT_EQ(again.held_out_from_prior, h.held_out_linearized);
    const double rmse = id.Rmse(again.AllValues(), val);
    EXPECT_NEAR(again.rmse_validation_mps2, rmse, 1e-4 * rmse);
    nlohmann::json hbad = hdoc;
    hbad["held_out"][0]["chunks"][0]["rss_a_y"] = -1.0;
    try {
      LinearizedWindow::FromJson(JsonIn(hbad, "linearized"));
      ADD_FAILURE() << "a negative held-out sum of squares was accepted";
    } catch (const CodecError& e) {
      EXPECT_NE(std::string(e.what()).find("linearized.held_out[0].chunks[0].rss"), std::string::npos) << e.what();
    }
  }
  EXPECT_EQ(back.segments[0].chunks[0].jtj, b.linearized->segments[0].chunks[0].jtj);
  EXPECT_EQ(back.segments.back().chunks.back().acf_a_y, b.linearized->segments.back().chunks.back().acf_a_y);
  // Both outputs (the example's): each chunk's yaw-rate part is kept, so the prior can be re-weighted.
  ASSERT_TRUE(b.linearized->Reweightable());
  EXPECT_TRUE(back.Reweightable());
  EXPECT_EQ(back.segments[0].chunks[0].jtj_yaw_rate, b.linearized->segments[0].chunks[0].jtj_yaw_rate);
  EXPECT_EQ(back.segments.back().chunks.back().score_yaw_rate, b.linearized->segments.back().chunks.back().score_yaw_rate);
  {  // A state written before the yaw-rate parts were kept still reads; it is not re-weighted.
    nlohmann::json old_state = doc;
    for (auto& seg : old_state["segments"])
      for (auto& ch : seg["chunks"]) {
        ch.erase("jtj_yaw_rate");
        ch.erase("score_yaw_rate");
      }
    const LinearizedWindow old_back = LinearizedWindow::FromJson(JsonIn(old_state, "linearized"));
    EXPECT_EQ(old_back.chunks(), b.linearized->chunks());
    EXPECT_FALSE(old_back.Reweightable());
    const IdentificationResult from_old =
        id.Identify(segs, {}, b.AllValues(), IncrementalUpdate{std::make_shared<LinearizedWindow>(old_back), 0.5, true});
    EXPECT_TRUE(from_old.valid) << from_old.reason;
  }
  const IdentificationResult from_back =
      id.Identify(segs, {}, b.AllValues(), IncrementalUpdate{std::make_shared<LinearizedWindow>(back), 0.5, true});
  const IdentificationResult from_mem = id.Identify(segs, {}, b.AllValues(), IncrementalUpdate{b.linearized, 0.5, true});
  EXPECT_EQ(from_back.eg_rad_per_mps2, from_mem.eg_rad_per_mps2);

  auto expect_refused = [&](nlohmann::json bad, const std::string& where) {
    try {
      LinearizedWindow::FromJson(JsonIn(bad, "linearized"));
      ADD_FAILURE() << "accepted: " << where;
    } catch (const CodecError& e) {
      EXPECT_NE(std::string(e.what()).find(where), std::string::npos) << e.what();
    }
  };
  nlohmann::json bad = doc;
  const double neg[] = {-1.0};
  auto jtj = LinearizedWindow::FromJson(JsonIn(doc, "linearized")).segments[0].chunks[0].jtj;
  jtj[0] = neg[0];
  bad["segments"][0]["chunks"][0]["jtj"] = DoublesToBinary(jtj.data(), jtj.size());
  expect_refused(bad, "linearized.segments[0].chunks[0].jtj");
  bad = doc;
  bad["segments"][0]["chunks"][0]["theta"] = DoublesToBinary(jtj.data(), 3);
  expect_refused(bad, "linearized.segments[0].chunks[0].theta");
  bad = doc;
  bad["scale"][1] = 0.0;
  expect_refused(bad, "linearized.scale[1]");
  bad = doc;
  bad["segments"][0]["chunks"][0]["rss"] = -2.0;
  expect_refused(bad, "linearized.segments[0].chunks[0].rss");
  bad = doc;
  bad["segments"][0]["chunks"][0]["jtj_yaw_rate"] = DoublesToBinary(jtj.data(), jtj.size());  // the negative diagonal
  expect_refused(bad, "linearized.segments[0].chunks[0].jtj_yaw_rate");
  bad = doc;
  bad["segments"][0]["chunks"][0].erase("score_yaw_rate");  // one part without the other
  expect_refused(bad, "linearized.segments[0].chunks[0]");
}

}  // namespace
}  // namespace ndsid::identify
