// Clocks that jump (docs/reliability.md): the bundled clean drives through the
// pipeline as recorded, with a frame stamped 10 years ahead, and with the clock stepped back by
// an hour in the middle. Nothing after a fault is lost, the future never becomes the data time,
// and EG agrees with the clean run.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>

#include "ndsid/can/frame_log.h"
#include "ndsid/config/config.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/pipeline/pipeline.h"

namespace ndsid {
namespace {

constexpr int64_t kYear = 365LL * 24 * 3600 * 1'000'000'000;

struct Outcome {
  double gated_h = 0;
  double eg = 0, eg_se = 0;
  int64_t data_time_ns = 0;
  int64_t first_ns = 0, last_ns = 0;  // of the log, raw
  sync::TimeBaseCounters time;
  uint64_t drives = 0;
};

// fault(index, frame) may change the frame's stamp; returns extra frames to insert after it.
template <class Fault>
Outcome Replay(const config::Config& cfg, const dbc::Database& db, Fault fault) {
  pipeline::Pipeline p(cfg, db);
  auto log = can::OpenFrameLog(cfg.source.logs.at(0));
  std::vector<can::CanFrame> buf(4096), batch;
  Outcome o;
  uint64_t index = 0;
  for (;;) {
    const auto r = log->Read(buf, 0);
    batch.clear();
    for (size_t i = 0; i < r.count; ++i) {
      if (index == 0) o.first_ns = buf[i].timestamp_ns;
      o.last_ns = buf[i].timestamp_ns;
      fault(index++, buf[i], batch);
    }
    p.ProcessFrames(batch, log->bus_names());
    if (r.state == can::SourceState::kEnd) break;
  }
  p.Finish();
  const auto& e = p.IdentifyNow();
  o.gated_h = p.accumulator().gated_hours();
  o.eg = e.fit.eg_deg_per_g;
  o.eg_se = e.fit.eg_se_deg_per_g;
  o.data_time_ns = p.data_time_ns();
  o.time = p.time_base().counters();
  o.drives = p.gate().counters().drives;
  return o;
}

class TimeFaults : public ::testing::Test {
 protected:
  void SetUp() override {
    cfg_ = config::LoadConfig(NDSID_SOURCE_DIR "/config/example_vehicle.yaml");
    db_ = dbc::ParseDbcFile(cfg_.dbc);
    clean_ = Replay(cfg_, db_, [](uint64_t, const can::CanFrame& f, std::vector<can::CanFrame>& out) { out.push_back(f); });
    std::printf("clean: %.4f gated h, EG %.4f +- %.4f deg/g, %llu drives\n", clean_.gated_h, clean_.eg, clean_.eg_se,
                static_cast<unsigned long long>(clean_.drives));
  }
  config::Config cfg_;
  dbc::Database db_;
  Outcome clean_;
};

// Catches: one frame 10 years ahead poisoning the run (later frames dropped as "time backwards",
// the future persisted as the data time).
TEST_F(TimeFaults, FrameFromTheFutureIsDropped) {
  const uint64_t at = 400'000;
  const Outcome o = Replay(cfg_, db_, [&](uint64_t i, can::CanFrame f, std::vector<can::CanFrame>& out) {
    if (i == at) f.timestamp_ns += 10 * kYear;
    out.push_back(f);
  });
  std::printf("spike: %.4f gated h, EG %.4f +- %.4f, spikes dropped %llu\n", o.gated_h, o.eg, o.eg_se,
              static_cast<unsigned long long>(o.time.spikes_dropped));
  EXPECT_EQ(o.time.spikes_dropped, 1u);
  EXPECT_LE(o.data_time_ns, o.last_ns) << "the future never becomes the data time";
  EXPECT_NEAR(o.gated_h, clean_.gated_h, 1e-3 * clean_.gated_h);
  EXPECT_NEAR(o.eg, clean_.eg, 0.1 * clean_.eg_se);
}

// Catches: everything after a clock step back discarded ("1 drives, 0.000 gated h").
TEST_F(TimeFaults, ClockSteppedBackLosesNothing) {
  for (const uint64_t at : {300'000ull, 500'000ull, 700'000ull}) {  // three places in the drives
    const Outcome o = Replay(cfg_, db_, [&](uint64_t i, can::CanFrame f, std::vector<can::CanFrame>& out) {
      if (i >= at) f.timestamp_ns -= 3600LL * 1'000'000'000;
      out.push_back(f);
    });
    std::printf("step back 1 h at frame %llu: %.4f gated h, EG %.4f +- %.4f, steps back %llu, %llu drives\n",
                static_cast<unsigned long long>(at), o.gated_h, o.eg, o.eg_se,
                static_cast<unsigned long long>(o.time.steps_back), static_cast<unsigned long long>(o.drives));
    EXPECT_EQ(o.time.steps_back, 1u);
    EXPECT_EQ(o.time.spikes_dropped, 0u);
    EXPECT_EQ(o.drives, clean_.drives) << "the drive goes on after the step";
    // The step cuts a segment: at most the samples around the cut are lost (under 0.5 %).
    EXPECT_GT(o.gated_h, 0.995 * clean_.gated_h);
    // The cut re-chunks the segment after it (60 s chunks, 1.5 s burn-in dropped at each start):
    // every later chunk drops a different 2.5 % of its samples, which moves EG by about
    // sqrt(0.025) = 0.16 sigma; allowed 3 times that. Measured 0.00-0.11 sigma with a_y alone,
    // 0.09, 0.00 and 0.25 sigma at these three places with both outputs (the default).
    EXPECT_NEAR(o.eg, clean_.eg, 0.5 * clean_.eg_se);
  }
}

}  // namespace
}  // namespace ndsid
