// `ndsid replay` runs its periodic fits on a worker beside the reading (desk/replay_runner.h),
// one at a time; a fit due while the last one runs takes its snapshot then and starts when that
// one has been accepted, the reading going on. The estimates must be those of fitting in line, the
// way the replay did before: the same due points, snapshots, warm starts and priors. A log
// simulated with two outputs is replayed both ways and every estimate compared.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <filesystem>

#include "ndsid/can/frame_log.h"
#include "sim_harness.h"

namespace ndsid {
namespace {

std::vector<pipeline::Estimate> InLine(const config::Config& config, const dbc::Database& db, const std::string& log) {
  pipeline::Pipeline p(config, db);
  const std::unique_ptr<can::FrameLog> reader = can::OpenFrameLog(log);
  std::vector<can::CanFrame> frames(256);  // the replay's batch: due is tested after each
  for (;;) {
    const can::ReadResult r = reader->Read(frames, 0);
    p.ProcessFrames(std::span<const can::CanFrame>(frames.data(), r.count), reader->bus_names());
    if (p.IdentificationDue()) p.IdentifyNow();
    if (r.state == can::SourceState::kEnd) break;
  }
  p.Finish();
  p.IdentifyNow(true);
  return p.history();
}

TEST(ReplayOverlap, FitsBesideTheReadingGiveTheEstimatesOfFittingInLine) {
  size_t queued = 0;
  for (uint64_t seed : {3u, 11u}) {
    config::SimulationConfig sim;
    sim.seed = seed;
    sim.duration.hours = 1.0;
    config::ApplyEffect(sim.effects, "gyro_offset_degps=0.3");
    config::Config config = config::LoadConfig(std::string(NDSID_SOURCE_DIR) + "/config/example_vehicle.yaml");
    config.identification.period_s = 300;  // many updates, most of them incremental
    const dbc::Database db = dbc::ParseDbcFile(config.dbc);
    const std::string dir = testing::TempDir("overlap" + std::to_string(seed));
    const std::string log = dir + "/drive.log";
    sim::WriteCandumpLog(sim::Simulate(sim), db, log);

    pipeline::Pipeline p(config, db);
    desk::ReplayOptions opt;
    opt.logs = {log};
    const desk::ReplayOutcome out = desk::RunReplay(p, config, opt);
    const std::vector<pipeline::Estimate> ref = InLine(config, db, log);
    std::filesystem::remove_all(dir);

    ASSERT_GE(ref.size(), 6u) << "seed " << seed << ": too few updates to compare";
    ASSERT_EQ(out.history.size(), ref.size()) << "seed " << seed;
    size_t incremental = 0;
    for (size_t i = 0; i < ref.size(); ++i) {
      const auto& a = out.history[i];
      const auto& b = ref[i];
      SCOPED_TRACE("seed " + std::to_string(seed) + ", update " + std::to_string(i));
      EXPECT_EQ(a.data_time_ns, b.data_time_ns);
      EXPECT_EQ(a.gated_hours, b.gated_hours);
      EXPECT_EQ(a.fit.valid, b.fit.valid);
      EXPECT_EQ(a.fit.update, b.fit.update);
      // The same inputs give the same numbers (to rounding of threaded sums, if any).
      EXPECT_NEAR(a.fit.eg_rad_per_mps2, b.fit.eg_rad_per_mps2, 1e-9 * std::abs(b.fit.eg_rad_per_mps2));
      EXPECT_NEAR(a.fit.eg_se_rad_per_mps2, b.fit.eg_se_rad_per_mps2, 1e-7 * b.fit.eg_se_rad_per_mps2);
      EXPECT_NEAR(a.fit.rmse_validation_mps2, b.fit.rmse_validation_mps2, 1e-9);
      EXPECT_EQ(a.adequacy.state, b.adequacy.state);
      EXPECT_EQ(a.plausibility.passed(), b.plausibility.passed());
      incremental += b.fit.chunks_from_prior > 0 ? 1 : 0;
    }
    EXPECT_GE(incremental, 3u) << "seed " << seed << ": the comparison should cover updates on a prior";
    EXPECT_GT(out.periodic_fit_wall_s, 0.0);
    queued += out.periodic_fits_queued;
    std::printf("seed %llu: %zu updates, %zu due while the last fit ran\n", static_cast<unsigned long long>(seed),
                ref.size(), out.periodic_fits_queued);
  }
  // Fits due while the last one ran wait with their snapshot, the reading going on: covered
  // when some did (reading 5 min of data takes milliseconds, a fit on two threads tens of them).
  EXPECT_GT(queued, 0u);
}

}  // namespace
}  // namespace ndsid
