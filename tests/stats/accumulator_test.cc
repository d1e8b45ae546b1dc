// Accumulator: the segment window (decimation, minimum segment length, eviction by window_h),
// the drive rule, and the binary persistence (round trip, truncation, corruption).
#include "ndsid/stats/accumulator.h"

#include <gtest/gtest.h>

#include <cmath>
#include <cstring>
#include <functional>
#include <limits>
#include <string>
#include <vector>

#include "ndsid/common/error.h"

namespace ndsid::stats {
namespace {

// The learned state as the state file carries it (CBOR), and back.
std::string Bytes(const Accumulator& a) { return ToCbor(a.ToJson()); }
void RestoreBytes(Accumulator& a, const std::string& bytes) {
  a.FromJson(JsonIn(ParseCbor(bytes, "test state"), "state.accumulator"));
}

constexpr double kSyncHz = 100.0;

config::Config SmallConfig(double window_h) {
  config::Config c;
  c.identification.rate_hz = 50.0;  // decimation by 2
  c.identification.window_h = window_h;
  c.gate.min_segment_s = 4.0;
  c.gate.min_drive_km = 0.5;
  return c;
}

struct Feeder {
  Accumulator& acc;
  int64_t drive_id = -1;
  int64_t t_ns = 0;
  double distance_m = 0;
  bool prev_accepted = false;
  bool rear_wheels = false;  // the samples carry the rear wheels' difference

  gate::GatedSample Next(bool accepted, bool new_drive = false) {
    if (new_drive) {
      ++drive_id;
      distance_m = 0;
      prev_accepted = false;
    }
    t_ns += 10'000'000;
    const double t = t_ns * 1e-9;
    gate::GatedSample g;
    g.sample.t_ns = t_ns;
    g.sample.speed_mps = 20;
    g.sample.steer_rad = 0.05 * std::sin(0.3 * t);
    g.sample.lat_accel_mps2 = 2.0 * std::sin(0.3 * t);
    g.sample.yaw_rate_radps = 0.1 * std::sin(0.3 * t);
    g.sample.has_yaw_rate = true;
    g.sample.rear_wheel_diff_mps = 0.155 * std::sin(0.3 * t);
    g.sample.has_rear_wheel_diff = rear_wheels;
    g.sample.valid = true;
    g.verdict = accepted ? gate::Verdict::kAccepted : gate::Verdict::kNonlinearRange;
    g.drive_id = drive_id;
    g.new_drive = new_drive;
    g.segment_start = accepted && !prev_accepted;
    g.quasi_steady = accepted;
    distance_m += 0.2;
    g.drive_distance_m = distance_m;
    prev_accepted = accepted;
    return g;
  }
  // `n` samples at 100 Hz, accepted or not; the first opens a new drive if asked.
  void Feed(int n, bool accepted, bool new_drive = false) {
    for (int i = 0; i < n; ++i) acc.Add(Next(accepted, new_drive && i == 0));
  }
};

double WindowSeconds(const Accumulator& acc) {
  double s = 0;
  for (const auto& seg : acc.window()) s += seg->duration_s();
  return s;
}

// Catches: decimation that does not average consecutive pairs, or a segment that starts at the
// wrong time or drops the odd last sample unaccounted.
TEST(AccumulatorWindow, SegmentsAreBoxcarDecimatedFromTheirFirstSample) {
  const config::Config config = SmallConfig(20);
  Accumulator acc(config, kSyncHz);
  Feeder f{acc};
  std::vector<gate::GatedSample> fed;
  for (int i = 0; i < 3001; ++i) {  // 30.01 s accepted: 2.5 km, a used drive
    fed.push_back(f.Next(true, i == 0));
    acc.Add(fed.back());
  }
  acc.Finish();
  ASSERT_EQ(acc.window().size(), 1u);
  const Segment& seg = *acc.window().front();
  EXPECT_EQ(seg.samples.size(), 1500u);  // the unpaired last sample is not emitted
  EXPECT_DOUBLE_EQ(seg.dt_s, 0.02);
  EXPECT_EQ(seg.t0_ns, fed.front().sample.t_ns);
  EXPECT_TRUE(seg.has_yaw_rate);
  for (size_t k = 0; k < seg.samples.size(); k += 97) {
    const auto& a = fed[2 * k].sample;
    const auto& b = fed[2 * k + 1].sample;
    const float steer = (static_cast<float>(a.steer_rad) + static_cast<float>(b.steer_rad)) * 0.5f;
    const float ay = (static_cast<float>(a.lat_accel_mps2) + static_cast<float>(b.lat_accel_mps2)) * 0.5f;
    EXPECT_EQ(seg.samples[k].steer_rad, steer) << k;
    EXPECT_EQ(seg.samples[k].lat_accel_mps2, ay) << k;
  }
}

// Catches: stretches shorter than min_segment_s entering the dynamic fit, or their samples not
// counted; drives shorter than min_drive_km not discarded (statistics, coverage and segments).
TEST(AccumulatorWindow, ShortSegmentsAndShortDrivesAreCountedNotKept) {
  const config::Config config = SmallConfig(20);
  Accumulator acc(config, kSyncHz);
  Feeder f{acc};
  f.Feed(1000, true, true);  // 10 s: a segment; 200 m, drive not yet used
  f.Feed(10, false);
  f.Feed(300, true);         // 3 s < min_segment_s
  f.Feed(10, false);
  f.Feed(2000, true);        // drive passes 0.5 km here
  f.Feed(500, true, true);   // a new drive of 100 m: ends short
  acc.Finish();
  EXPECT_EQ(acc.counters().short_segment_samples, 300u);
  EXPECT_EQ(acc.counters().short_drive_samples, 500u);
  ASSERT_EQ(acc.window().size(), 2u);
  EXPECT_DOUBLE_EQ(WindowSeconds(acc), 30.0);
  ASSERT_EQ(acc.drives().size(), 2u);
  EXPECT_TRUE(acc.drives()[0].used);
  EXPECT_FALSE(acc.drives()[1].used);
  EXPECT_NEAR(acc.gated_hours() * 3600, 33.0, 1e-9);  // accepted time of the used drive only
  EXPECT_EQ(acc.steady_state().without_yaw().n(), 3300);
  EXPECT_EQ(acc.coverage().gg().total(), 3300);
}

// Catches: a window that keeps more than window_h (beyond the oldest segment needed to reach
// it), evicts recent data before old, or forgets to count evictions — after every Add, including
// when a drive's held-back segments are committed at once.
TEST(AccumulatorWindow, EvictsOldestSegmentsBeyondWindowHours) {
  const double window_h = 60.0 / 3600;  // one minute
  const config::Config config = SmallConfig(window_h);
  Accumulator acc(config, kSyncHz);
  Feeder f{acc};
  uint64_t kept_or_evicted = 0;
  for (int drive = 0; drive < 4; ++drive) {
    // 40 s of 8 s segments before the drive reaches 0.5 km (held back), then 40 s more.
    for (int s = 0; s < 10; ++s) {
      f.Feed(800, true, s == 0);
      f.Feed(5, false);
      ++kept_or_evicted;
      const double total = WindowSeconds(acc);
      if (!acc.window().empty()) {
        EXPECT_LT(total - acc.window().front()->duration_s(), window_h * 3600) << "drive " << drive << " segment " << s;
      }
    }
  }
  acc.Finish();
  EXPECT_EQ(acc.window().size() + acc.counters().evicted_segments, kept_or_evicted);
  EXPECT_GE(WindowSeconds(acc), window_h * 3600);
  // Oldest first, and the newest segment is kept.
  for (size_t i = 1; i < acc.window().size(); ++i) EXPECT_LT(acc.window()[i - 1]->t0_ns, acc.window()[i]->t0_ns);
  EXPECT_EQ(acc.window().back()->t0_ns, f.t_ns - int64_t{804} * 10'000'000);
}

// Catches: an identification holding a copy of the window losing its segments when the window
// moves on (the header promises shared, immutable segments).
TEST(AccumulatorWindow, CopiedWindowOutlivesEviction) {
  const config::Config config = SmallConfig(20.0 / 3600);
  Accumulator acc(config, kSyncHz);
  Feeder f{acc};
  f.Feed(3000, true, true);
  f.Feed(5, false);
  const auto copy = acc.window();
  ASSERT_EQ(copy.size(), 1u);
  const size_t n = copy.front()->samples.size();
  f.Feed(3000, true);
  f.Feed(5, false);
  EXPECT_NE(acc.window().front(), copy.front());  // evicted from the live window
  EXPECT_EQ(copy.front()->samples.size(), n);     // still whole in the copy
}

Accumulator Learned(const config::Config& config) {
  Accumulator acc(config, kSyncHz);
  Feeder f{acc};
  f.Feed(3000, true, true);
  f.Feed(20, false);
  f.Feed(250, true);  // short segment
  f.Feed(1200, true, true);
  f.Feed(2000, true);  // 640 m: used; the segment is still open, Serialize() closes it
  return acc;
}

// Catches: persistence that changes the learned state (bit for bit, doubles and floats are
// copied as bytes), or a Serialize() that modifies the object.
TEST(AccumulatorState, RoundTripIsByteIdentical) {
  const config::Config config = SmallConfig(20);
  for (int which = 0; which < 2; ++which) {
    Accumulator a = which == 0 ? Accumulator(config, kSyncHz) : Learned(config);
    const std::string bytes = Bytes(a);
    EXPECT_EQ(Bytes(a), bytes);  // ToJson() does not change the object
    Accumulator b(config, kSyncHz);
    RestoreBytes(b, bytes);
    EXPECT_EQ(Bytes(b), bytes);
    EXPECT_EQ(b.steady_state(), SteadyStateStats::FromJson(JsonIn(a.steady_state().ToJson(), "t")));
    EXPECT_EQ(b.window().size(), which == 0 ? 0u : 1u);  // the second drive's segment is still open
  }
}

// Catches: a truncated state file (power loss mid-write) restored as a shorter state, or a crash
// on it; and a failed restore that leaves the accumulator half-replaced.
TEST(AccumulatorState, EveryTruncationIsRejectedAndLeavesTheObjectUnchanged) {
  const config::Config config = SmallConfig(20);
  const std::string bytes = Bytes(Learned(config));
  Accumulator target = Learned(config);
  const std::string before = Bytes(target);
  // Every length through the header, blobs, drives and first segment header; then every
  // 997th byte through the segment samples, and the last byte missing.
  for (size_t len = 0; len < bytes.size(); len += (len < 600 ? 1 : 997)) {
    EXPECT_THROW(RestoreBytes(target, bytes.substr(0, len)), Error) << len;
  }
  EXPECT_THROW(RestoreBytes(target, bytes.substr(0, bytes.size() - 1)), Error);
  EXPECT_THROW(RestoreBytes(target, bytes + '\0'), Error);  // trailing byte
  EXPECT_EQ(Bytes(target), before);
}

// Catches: corrupted values (NaN, negative values, a wrong type, a non-finite sample, an open
// drive without its parts) restored instead of rejected, with the path of the bad value named.
TEST(AccumulatorState, CorruptedValuesAreRejected) {
  const config::Config config = SmallConfig(20);
  Accumulator finished = Learned(config);
  finished.Finish();
  const nlohmann::json good = finished.ToJson();
  Accumulator target(config, kSyncHz);
  auto rejects = [&](const std::function<void(nlohmann::json&)>& edit, const std::string& path) {
    nlohmann::json j = good;
    edit(j);
    try {
      RestoreBytes(target, ToCbor(j));
      ADD_FAILURE() << "accepted a state with a bad " << path;
    } catch (const CodecError& e) {
      EXPECT_NE(std::string(e.what()).find(path), std::string::npos) << e.what();
    }
  };
  rejects([](nlohmann::json& j) { j["gated_s"] = std::numeric_limits<double>::quiet_NaN(); }, "state.accumulator.gated_s");
  rejects([](nlohmann::json& j) { j["gated_s"] = -1.0; }, "state.accumulator.gated_s");
  rejects([](nlohmann::json& j) { j["gated_s"] = "1"; }, "state.accumulator.gated_s");
  rejects([](nlohmann::json& j) { j["counters"]["evicted_segments"] = -3; }, "state.accumulator.counters.evicted_segments");
  rejects([](nlohmann::json& j) { j["drives"][0]["end_ns"] = j["drives"][0]["start_ns"].get<int64_t>() - 1; }, "state.accumulator.drives[0]");
  rejects([](nlohmann::json& j) { j["steady_state"]["with_yaw"]["xtx"][4] = std::numeric_limits<double>::infinity(); },
          "state.accumulator.steady_state.with_yaw.xtx[4]");
  rejects([](nlohmann::json& j) { j["coverage"]["gg"].erase(0); }, "state.accumulator.coverage.gg");
  rejects([](nlohmann::json& j) { j.erase("window"); }, "state.accumulator.window");
  // The last segment sample's last float (long acceleration) set to NaN.
  rejects([](nlohmann::json& j) {
            auto& bytes = j["window"].back()["samples"].get_binary();
            bytes[bytes.size() - 1] = 0x7f, bytes[bytes.size() - 2] = 0xc0;
            bytes[bytes.size() - 3] = 0, bytes[bytes.size() - 4] = 0;
          },
          "state.accumulator.window[1].samples");
  rejects([](nlohmann::json& j) { j["window"][0]["samples"].get_binary().pop_back(); }, "state.accumulator.window[0].samples");
  // An open drive that is neither null nor carries its parts.
  rejects([](nlohmann::json& j) { j["open_drive"] = nlohmann::json::object(); }, "state.accumulator.open_drive.used");
  EXPECT_TRUE(target.window().empty());
}

// The drive in progress across a restart. `restart_at` samples into the second
// drive the state is serialized and restored into a fresh accumulator, and the data go on from a
// gate that starts again (its drive 0, distance from 0), `gap_s` later.
struct Fed {
  Accumulator acc;
  Feeder f;
  explicit Fed(const config::Config& c) : acc(c, kSyncHz), f{acc} {}
};
void FeedDrives(Feeder& f, int from, int to) {
  // Drive 0: 3000 accepted samples (600 m, used). Drive 1: 1000 accepted, 30 not, 1500
  // accepted (two segments; min_drive_km 0.5 is reached at sample 2500, 500 m).
  for (int i = from; i < to; ++i) {
    const bool new_drive = i == 0 || i == 3000;
    const bool accepted = !(i >= 4000 && i < 4030);
    f.acc.Add(f.Next(accepted, new_drive));
  }
}
constexpr int kTotal = 5530;

// Catches: a restart in the middle of a drive that drops its held-back data (the drive short of
// min_drive_km at the restart), renumbers it (a different held-out split), or counts it twice.
TEST(AccumulatorState, TheDriveInProgressGoesOnAfterARestart) {
  const config::Config config = SmallConfig(20);
  Fed whole(config);
  FeedDrives(whole.f, 0, kTotal);
  whole.acc.Finish();
  for (int restart_at : {3300, 4015, 5000}) {  // held back (short), between segments, used
    Fed before(config);
    FeedDrives(before.f, 0, restart_at);
    Fed after(config);
    RestoreBytes(after.acc, Bytes(before.acc));
    after.f.t_ns = before.f.t_ns;  // the data go on; the gate starts again
    after.f.distance_m = 0;
    after.f.drive_id = -1;
    after.f.prev_accepted = false;
    after.acc.Add(after.f.Next(!(restart_at >= 4000 && restart_at < 4030), true));
    FeedDrives(after.f, restart_at + 1, kTotal);
    after.acc.Finish();
    ASSERT_EQ(after.acc.drives().size(), 2u) << restart_at;
    EXPECT_EQ(after.acc.drives()[1].drive_id, 1) << restart_at;
    EXPECT_TRUE(after.acc.drives()[1].used) << restart_at;
    EXPECT_NEAR(after.acc.drives()[1].distance_km, whole.acc.drives()[1].distance_km, 0.0002 + 1e-9) << restart_at;  // one step
    EXPECT_NEAR(after.acc.gated_hours(), whole.acc.gated_hours(), 1e-12) << restart_at;
    EXPECT_EQ(after.acc.steady_state().with_yaw().n(), whole.acc.steady_state().with_yaw().n()) << restart_at;
    // The same samples in the window but for the cut: drive 1's segment is cut in two at the
    // restart, and a piece shorter than min_segment_s (4 s = 200 samples at 50 Hz) is counted
    // as a short segment, as any gated stretch that short.
    size_t n_after = 0, n_whole = 0;
    for (const auto& seg : after.acc.window()) {
      n_after += seg->samples.size();
      EXPECT_LE(seg->drive_id, 1);
    }
    for (const auto& seg : whole.acc.window()) n_whole += seg->samples.size();
    EXPECT_LE(n_after, n_whole) << restart_at;
    EXPECT_LE(n_whole - n_after, 201u) << restart_at;
    EXPECT_NEAR(static_cast<double>(after.acc.counters().short_segment_samples - whole.acc.counters().short_segment_samples),
                2.0 * static_cast<double>(n_whole - n_after), 2.0)
        << restart_at;
    EXPECT_EQ(after.acc.counters().short_drive_samples, 0u) << restart_at;
  }
}

// Catches: a restart that cuts the gated segment although the data are re-read seamlessly. The
// daemon re-reads a log from a few seconds before its resume point (warming up the sync stage
// and the gate) and tells the accumulator to skip what it has: then the window must be the
// uninterrupted run's, segment for segment and sample for sample.
TEST(AccumulatorState, AWarmedUpRestartContinuesTheOpenSegmentExactly) {
  const config::Config config = SmallConfig(20);
  for (const bool wheels : {false, true}) {  // with the rear wheels' difference: its partial sum too
  Fed whole(config);
  whole.f.rear_wheels = wheels;
  FeedDrives(whole.f, 0, kTotal);
  whole.acc.Finish();
  for (int restart_at : {3300, 3999, 5000}) {
    Fed before(config);
    before.f.rear_wheels = wheels;
    FeedDrives(before.f, 0, restart_at);
    Fed after(config);
    after.f.rear_wheels = wheels;
    RestoreBytes(after.acc, Bytes(before.acc));
    after.acc.SkipThrough(before.acc.last_sample_ns());
    constexpr int kWarmup = 100;  // 1 s at 100 Hz
    after.f.t_ns = before.f.t_ns - kWarmup * 10'000'000;
    after.f.drive_id = -1;
    after.f.distance_m = 0;
    after.f.prev_accepted = false;
    for (int i = restart_at - kWarmup; i < kTotal; ++i) {
      const bool accepted = !(i >= 4000 && i < 4030);
      after.acc.Add(after.f.Next(accepted, i == restart_at - kWarmup || i == 3000));
    }
    after.acc.Finish();
    ASSERT_EQ(after.acc.window().size(), whole.acc.window().size()) << restart_at;
    for (size_t k = 0; k < whole.acc.window().size(); ++k) {
      const Segment& a = *after.acc.window()[k];
      const Segment& w = *whole.acc.window()[k];
      EXPECT_EQ(a.t0_ns, w.t0_ns) << restart_at << " segment " << k;
      EXPECT_EQ(a.drive_id, w.drive_id) << restart_at << " segment " << k;
      ASSERT_EQ(a.samples.size(), w.samples.size()) << restart_at << " segment " << k;
      EXPECT_EQ(0, std::memcmp(a.samples.data(), w.samples.data(), a.samples.size() * sizeof(SegmentSample)))
          << restart_at << " segment " << k;
    }
    EXPECT_NEAR(after.acc.gated_hours(), whole.acc.gated_hours(), 1e-12) << restart_at;
    EXPECT_EQ(after.acc.counters().short_segment_samples, whole.acc.counters().short_segment_samples) << restart_at;
  }
  }
}

// Catches: an open drive continued although the data resumed after a key cycle: it must end
// there as Finish() would have ended it (short: dropped and counted), the new drive numbered
// after it.
TEST(AccumulatorState, ARestartAfterAKeyCycleEndsTheOpenDrive) {
  config::Config config = SmallConfig(20);
  config.gate.drive_gap_s = 60;
  Fed before(config);
  FeedDrives(before.f, 0, 3300);  // drive 1 short (60 m), held back
  Fed after(config);
  RestoreBytes(after.acc, Bytes(before.acc));
  after.f.t_ns = before.f.t_ns + 120'000'000'000;  // two minutes later
  after.f.drive_id = -1;
  after.f.distance_m = 0;
  after.f.Feed(3000, true, true);
  after.acc.Finish();
  ASSERT_EQ(after.acc.drives().size(), 3u);
  EXPECT_FALSE(after.acc.drives()[1].used);
  EXPECT_EQ(after.acc.drives()[2].drive_id, 2);
  EXPECT_TRUE(after.acc.drives()[2].used);
  EXPECT_EQ(after.acc.counters().short_drive_samples, 300u);
  for (const auto& seg : after.acc.window()) EXPECT_NE(seg->drive_id, 1);
}

// Catches: a restored state learned with a longer window_h kept whole under a shorter one.
TEST(AccumulatorState, RestoreUnderAShorterWindowEvicts) {
  const config::Config long_window = SmallConfig(20), short_window = SmallConfig(15.0 / 3600);
  Accumulator a = Learned(long_window);
  a.Finish();
  const std::string bytes = Bytes(a);
  Accumulator b(short_window, kSyncHz);
  RestoreBytes(b, bytes);
  ASSERT_EQ(b.window().size(), 1u);  // 30 s + 32 s: the older 30 s segment is beyond 15 s
  EXPECT_EQ(b.counters().evicted_segments, 1u);
}

}  // namespace
}  // namespace ndsid::stats

namespace ndsid::stats {
namespace {

// Catches: the rear wheels' difference lost in the window or the learned state, a state without
// it read as having it, or a column of the wrong length or with a NaN restored.
TEST(AccumulatorState, TheRearWheelDifferenceIsKeptAndRestored) {
  const config::Config config = SmallConfig(20);
  Accumulator a(config, kSyncHz);
  Feeder f{a};
  f.rear_wheels = true;
  f.Feed(3000, true, true);  // 600 m: the drive is used
  f.Feed(10, false);
  ASSERT_EQ(a.window().size(), 1u);
  const Segment& seg = *a.window().front();
  ASSERT_TRUE(seg.has_rear_wheel_diff);
  // Decimated by 2 from 100 Hz: the mean of two consecutive samples of 0.155 sin(0.3 t).
  const double t0 = 0.01, t1 = 0.02;
  EXPECT_NEAR(seg.samples[0].rear_wheel_diff_mps, 0.5 * 0.155 * (std::sin(0.3 * t0) + std::sin(0.3 * t1)), 1e-6);
  const std::string bytes = Bytes(a);
  Accumulator b(config, kSyncHz);
  RestoreBytes(b, bytes);
  EXPECT_EQ(Bytes(b), bytes);
  ASSERT_EQ(b.window().size(), 1u);
  EXPECT_TRUE(b.window().front()->has_rear_wheel_diff);
  EXPECT_EQ(b.window().front()->samples.back().rear_wheel_diff_mps, seg.samples.back().rear_wheel_diff_mps);
  nlohmann::json j = a.ToJson();
  j["window"][0].erase("rear_wheel_diff");  // a state written without the column
  RestoreBytes(b, ToCbor(j));
  EXPECT_FALSE(b.window().front()->has_rear_wheel_diff);
  j = a.ToJson();
  j["window"][0]["rear_wheel_diff"].get_binary().resize(8);
  EXPECT_THROW(RestoreBytes(b, ToCbor(j)), CodecError);
  j = a.ToJson();
  auto& col = j["window"][0]["rear_wheel_diff"].get_binary();
  col[0] = 0, col[1] = 0, col[2] = 0xc0, col[3] = 0x7f;  // a NaN (little endian)
  EXPECT_THROW(RestoreBytes(b, ToCbor(j)), CodecError);
}

}  // namespace
}  // namespace ndsid::stats
