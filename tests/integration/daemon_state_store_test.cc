// The daemon's learned state: accumulator persistence, the state file's checks, quarantine,
// and the sanity checks on restore.
#include <gtest/gtest.h>

#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <limits>

#include "daemon_test_config.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/stats/accumulator.h"
#include "state_store.h"

namespace ndsid {
namespace {

namespace fs = std::filesystem;

// `seconds` of accepted samples at 100 Hz and 20 m/s with a slow steering sine, one drive.
void FeedDrive(stats::Accumulator& acc, int64_t drive_id, int64_t t0_ns, double seconds, double from_s = 0) {
  const double dt = 0.01;
  for (double t = from_s; t < seconds; t += dt) {
    gate::GatedSample g;
    g.sample.t_ns = t0_ns + static_cast<int64_t>(std::llround(t * 1e9));
    g.sample.speed_mps = 20;
    g.sample.steer_rad = 0.05 * std::sin(0.3 * t);
    g.sample.lat_accel_mps2 = 2.0 * std::sin(0.3 * t);
    g.sample.yaw_rate_radps = 0.1 * std::sin(0.3 * t);
    g.sample.has_yaw_rate = true;
    g.sample.valid = true;
    g.verdict = gate::Verdict::kAccepted;
    g.drive_id = drive_id;
    g.new_drive = t == from_s && from_s == 0;
    g.segment_start = g.new_drive;
    g.quasi_steady = true;
    g.drive_distance_m = 20 * t;
    acc.Add(g);
  }
}

class StateTest : public ::testing::Test {
 protected:
  void SetUp() override {
    dir_ = fs::temp_directory_path() / ("ndsid_state_test_" + std::to_string(::getpid()) + "_" +
                                        ::testing::UnitTest::GetInstance()->current_test_info()->name());
    fs::remove_all(dir_);
    config_ = testing::DaemonTestConfig({{"STATE_DIR", dir_.string()}});
  }
  void TearDown() override { fs::remove_all(dir_); }

  service::LearnedState MakeState() {
    stats::Accumulator acc(config_, config_.sync.rate_hz);
    FeedDrive(acc, 0, 0, 200);  // 4 km: used
    service::LearnedState st;
    st.vehicle = config_.vehicle.name;
    st.data_time_ns = 200'000'000'000;
    st.identifications = 3;
    st.last_fit_gated_hours = acc.gated_hours();
    st.accumulator = acc.Serialize();
    adequacy::Tracker tracker(config_.adequacy);
    tracker.Update(acc.gated_hours(), 2e-3, 1e-5, acc.coverage());
    st.adequacy = tracker.Serialize();
    pipeline::Estimate e;
    e.fit.valid = true;
    const double values[] = {1900, 2700, 78000, 122000, 1.15, 14.8};
    for (int i = 0; i < model::kNumParams; ++i) e.fit.params[i].value = values[i];
    e.fit.params[0].fixed = true;
    e.fit.eg_rad_per_mps2 = model::SelfSteerGradient(e.fit.AsParams(), config_.vehicle.wheelbase_m);
    e.fit.eg_deg_per_g = model::EgToDegPerG(e.fit.eg_rad_per_mps2);
    e.fit.reason = "line one\nline two";
    e.gated_hours = acc.gated_hours();
    st.last_estimate = e;
    return st;
  }

  fs::path dir_;
  config::Config config_;
};

TEST(AccumulatorPersistence, RestoreGivesSameStatisticsWindowAndDrives) {
  const config::Config c = testing::DaemonTestConfig();
  stats::Accumulator a(c, c.sync.rate_hz);
  FeedDrive(a, 0, 0, 150);
  FeedDrive(a, 1, 1'000'000'000'000, 150);
  a.Finish();
  stats::Accumulator b(c, c.sync.rate_hz);
  b.Restore(a.Serialize());
  EXPECT_DOUBLE_EQ(b.gated_hours(), a.gated_hours());
  EXPECT_TRUE(b.steady_state() == a.steady_state());
  EXPECT_EQ(b.coverage().Serialize(), a.coverage().Serialize());
  ASSERT_EQ(b.window().size(), a.window().size());
  for (size_t i = 0; i < a.window().size(); ++i) {
    ASSERT_EQ(b.window()[i]->samples.size(), a.window()[i]->samples.size());
    EXPECT_EQ(0, std::memcmp(b.window()[i]->samples.data(), a.window()[i]->samples.data(),
                             a.window()[i]->samples.size() * sizeof(stats::SegmentSample)));
    EXPECT_EQ(b.window()[i]->drive_id, a.window()[i]->drive_id);
  }
  ASSERT_EQ(b.drives().size(), 2u);
  EXPECT_TRUE(b.drives()[1].used);
  EXPECT_EQ(b.Serialize(), a.Serialize());
}

TEST(AccumulatorPersistence, SerializeMidDriveLeavesTheAccumulatorUnchanged) {
  const config::Config c = testing::DaemonTestConfig();
  stats::Accumulator a(c, c.sync.rate_hz), b(c, c.sync.rate_hz);
  FeedDrive(a, 0, 0, 60);
  FeedDrive(b, 0, 0, 60);
  const std::string mid = a.Serialize();  // drive still open, 1.2 km: not yet used
  EXPECT_FALSE(mid.empty());
  FeedDrive(a, 0, 0, 200, 60);
  FeedDrive(b, 0, 0, 200, 60);
  EXPECT_EQ(a.Serialize(), b.Serialize());
  EXPECT_GT(a.gated_hours(), 0.05);
}

TEST(AccumulatorPersistence, OpenDriveShorterThanMinimumIsNotPersisted) {
  const config::Config c = testing::DaemonTestConfig();
  stats::Accumulator a(c, c.sync.rate_hz);
  FeedDrive(a, 0, 0, 60);  // 1.2 km < min_drive_km = 2
  stats::Accumulator b(c, c.sync.rate_hz);
  b.Restore(a.Serialize());
  EXPECT_EQ(b.gated_hours(), 0.0);
  EXPECT_TRUE(b.window().empty());
}

TEST(AccumulatorPersistence, DrivesAfterRestoreAreNumberedAfterRestoredOnes) {
  const config::Config c = testing::DaemonTestConfig();
  stats::Accumulator a(c, c.sync.rate_hz);
  FeedDrive(a, 0, 0, 150);
  FeedDrive(a, 1, 1'000'000'000'000, 150);
  stats::Accumulator b(c, c.sync.rate_hz);
  b.Restore(a.Serialize());
  FeedDrive(b, 0, 2'000'000'000'000, 150);  // the gate numbers from 0 again after a restart
  b.Finish();
  ASSERT_EQ(b.drives().size(), 3u);
  EXPECT_EQ(b.drives().back().drive_id, 2);
  EXPECT_EQ(b.window().back()->drive_id, 2);
}

TEST(AccumulatorPersistence, NonFiniteSegmentSampleIsRejectedAndTargetUntouched) {
  const config::Config c = testing::DaemonTestConfig();
  stats::Accumulator a(c, c.sync.rate_hz);
  FeedDrive(a, 0, 0, 150);
  a.Finish();  // the state then ends with the last window segment and the open-drive flag 0
  std::string bytes = a.Serialize();
  const float nan = std::nanf("");
  std::memcpy(bytes.data() + bytes.size() - 1 - sizeof(float), &nan, sizeof nan);  // last sample's a_x
  stats::Accumulator b(c, c.sync.rate_hz);
  FeedDrive(b, 0, 0, 150);
  const std::string before = b.Serialize();
  EXPECT_THROW(b.Restore(bytes), Error);
  EXPECT_EQ(b.Serialize(), before);
  EXPECT_THROW(b.Restore(bytes.substr(0, bytes.size() / 2)), Error);
}

TEST_F(StateTest, FileRoundTripsEveryLearnedValue) {
  const service::LearnedState st = MakeState();
  const service::LearnedState back = service::DecodeState(service::EncodeState(st), config_.vehicle.name);
  EXPECT_EQ(back.accumulator, st.accumulator);
  EXPECT_EQ(back.adequacy, st.adequacy);
  EXPECT_EQ(back.data_time_ns, st.data_time_ns);
  EXPECT_EQ(back.identifications, 3);
  ASSERT_TRUE(back.last_estimate);
  EXPECT_EQ(back.last_estimate->fit.eg_rad_per_mps2, st.last_estimate->fit.eg_rad_per_mps2);
  EXPECT_EQ(back.last_estimate->fit.params[5].value, 14.8);
  EXPECT_TRUE(back.last_estimate->fit.params[0].fixed);
  EXPECT_EQ(back.last_estimate->fit.reason, "line one line two");
}

// Standstill stops (the evidence on the gyro offset and the accelerometer bias) are part of the
// learned state: a restart keeps them instead of starting the evidence again.
std::vector<gate::StandstillStop> TwoStops() {
  gate::StandstillStop a;
  a.drive_id = 0;
  a.t_start_ns = 12'000'000'000;
  a.seconds = 14.37;
  a.samples = 1437;
  a.mean_lat_accel_mps2 = 0.123456789012345;
  a.mean_yaw_rate_radps = -0.0069813170079773;
  gate::StandstillStop b = a;
  b.t_start_ns = 80'000'000'000;
  b.samples = 300;
  b.seconds = 3.0;
  b.mean_lat_accel_mps2 = -0.05;
  b.mean_yaw_rate_radps = std::numeric_limits<double>::quiet_NaN();  // a bus without a yaw rate
  return {a, b};
}

// Re-seals a state file after editing its standstill section (the section's length, the
// header's size and checksum).
std::string EditPayload(const std::string& bytes, const std::string& from, const std::string& to) {
  const size_t body = bytes.find("\n\n") + 2;
  std::string payload = bytes.substr(body);
  const size_t at = payload.find(from);
  EXPECT_NE(at, std::string::npos) << from;
  if (at == std::string::npos) return bytes;
  payload.replace(at, from.size(), to);
  const size_t head = payload.find("standstill ");
  EXPECT_NE(head, std::string::npos);
  if (head == std::string::npos) return bytes;
  const size_t eol = payload.find('\n', head);
  const long n = std::stol(payload.substr(head + 11, eol - head - 11)) + static_cast<long>(to.size()) - static_cast<long>(from.size());
  payload.replace(head, eol - head, "standstill " + std::to_string(n));
  const size_t l3 = bytes.find('\n', bytes.find('\n') + 1) + 1;  // after the vehicle line
  char checksum[17];
  std::snprintf(checksum, sizeof checksum, "%016llx", static_cast<unsigned long long>(service::Fnv1a64(payload)));
  return bytes.substr(0, l3) + "payload_bytes " + std::to_string(payload.size()) + "\npayload_fnv1a64 " + checksum + "\n\n" +
         payload;
}

TEST_F(StateTest, StandstillStopsRoundTripExactly) {
  service::LearnedState st = MakeState();
  st.stops = TwoStops();
  const service::LearnedState back = service::DecodeState(service::EncodeState(st), config_.vehicle.name);
  ASSERT_EQ(back.stops.size(), 2u);
  for (size_t i = 0; i < 2; ++i) {
    EXPECT_EQ(back.stops[i].drive_id, st.stops[i].drive_id);
    EXPECT_EQ(back.stops[i].t_start_ns, st.stops[i].t_start_ns);
    EXPECT_EQ(back.stops[i].seconds, st.stops[i].seconds);
    EXPECT_EQ(back.stops[i].samples, st.stops[i].samples);
    EXPECT_EQ(back.stops[i].mean_lat_accel_mps2, st.stops[i].mean_lat_accel_mps2);
  }
  EXPECT_EQ(back.stops[0].mean_yaw_rate_radps, st.stops[0].mean_yaw_rate_radps);
  EXPECT_TRUE(std::isnan(back.stops[1].mean_yaw_rate_radps));
  // A state written before stops were persisted (no section) loads with none.
  const service::LearnedState old = service::DecodeState(service::EncodeState(MakeState()), config_.vehicle.name);
  EXPECT_TRUE(old.stops.empty());
  EXPECT_EQ(service::EncodeState(MakeState()).find("standstill"), std::string::npos);
}

TEST_F(StateTest, MalformedStandstillStopIsCorruptAndLocated) {
  service::LearnedState st = MakeState();
  st.stops = TwoStops();
  const std::string bytes = service::EncodeState(st);
  const struct {
    const char* from;
    const char* to;
    const char* says;
  } cases[] = {{"\"samples\":300", "\"samples\":0  ", "stop 1: out of range"},
               {"\"seconds\":3.0", "\"seconds\":\"3\"", "stop 1: 'seconds' missing or not a number"},
               {"\"drive\":0", "\"drive\":0.5", "stop 0: 'drive' is not an integer"},
               {"[{", "[[{", "standstill section: [json.exception.parse_error"},
               {"\"mean_yaw_rate_radps\":null", "\"mean_yaw_rate_radps\":true", "stop 1: 'mean_yaw_rate_radps' not a number"}};
  for (const auto& c : cases) {
    try {
      service::DecodeState(EditPayload(bytes, c.from, c.to), config_.vehicle.name);
      ADD_FAILURE() << "no error for " << c.to;
    } catch (const service::StateFileError& e) {
      EXPECT_EQ(e.kind(), service::StateFileError::Kind::kCorrupt);
      EXPECT_NE(std::string(e.what()).find(c.says), std::string::npos) << e.what();
    }
  }
}

TEST_F(StateTest, RestoreGivesThePipelineTheStops) {
  const dbc::Database db = dbc::ParseDbcFile(config_.dbc);
  pipeline::Pipeline pipeline(config_, db);
  service::LearnedState st = MakeState();
  st.stops = TwoStops();
  std::string dropped;
  service::RestoreState(pipeline, config_, st, dropped);
  ASSERT_EQ(pipeline.stops().size(), 2u);
  EXPECT_EQ(pipeline.stops()[0].mean_yaw_rate_radps, st.stops[0].mean_yaw_rate_radps);
  const service::LearnedState again = service::CaptureState(pipeline, config_, 3);
  ASSERT_EQ(again.stops.size(), 2u);
  EXPECT_EQ(again.stops[1].t_start_ns, st.stops[1].t_start_ns);
}

TEST_F(StateTest, FlippedPayloadByteIsCorrupt) {
  std::string bytes = service::EncodeState(MakeState());
  bytes[bytes.size() - 100] ^= 0x01;
  try {
    service::DecodeState(bytes, config_.vehicle.name);
    FAIL() << "no error";
  } catch (const service::StateFileError& e) {
    EXPECT_EQ(e.kind(), service::StateFileError::Kind::kCorrupt);
    EXPECT_NE(std::string(e.what()).find("checksum"), std::string::npos) << e.what();
  }
}

TEST_F(StateTest, TruncatedFileIsCorrupt) {
  const std::string bytes = service::EncodeState(MakeState());
  for (size_t n : {size_t{0}, size_t{10}, bytes.size() / 2, bytes.size() - 1}) {
    try {
      service::DecodeState(bytes.substr(0, n), config_.vehicle.name);
      FAIL() << "no error at " << n;
    } catch (const service::StateFileError& e) {
      EXPECT_EQ(e.kind(), service::StateFileError::Kind::kCorrupt) << n;
    }
  }
}

TEST_F(StateTest, OtherVehicleIsForeignAndOtherVersionIncompatible) {
  const std::string bytes = service::EncodeState(MakeState());
  try {
    service::DecodeState(bytes, "another-car");
    FAIL();
  } catch (const service::StateFileError& e) {
    EXPECT_EQ(e.kind(), service::StateFileError::Kind::kForeign);
  }
  std::string v2 = bytes;
  v2.replace(0, 13, "NDSID-STATE 2");
  try {
    service::DecodeState(v2, config_.vehicle.name);
    FAIL();
  } catch (const service::StateFileError& e) {
    EXPECT_EQ(e.kind(), service::StateFileError::Kind::kIncompatible);
  }
}

TEST_F(StateTest, StoreMovesCorruptFileAsideAndStartsFresh) {
  service::StateStore store(dir_.string(), config_.vehicle.name);
  store.Save(MakeState());
  ASSERT_TRUE(store.Load().state);
  std::string bytes = ReadWholeFile(store.path());
  bytes[bytes.size() / 2] ^= 0x20;
  WriteFileAtomically(store.path(), bytes);
  const auto r = store.Load();
  EXPECT_FALSE(r.state);
  EXPECT_FALSE(fs::exists(store.path()));
  int corrupt = 0;
  for (const auto& e : fs::directory_iterator(dir_)) corrupt += e.path().filename().string().find(".corrupt-") != std::string::npos;
  EXPECT_EQ(corrupt, 1) << r.message;
}

// Catches: a state that exists but cannot be read replaced by a fresh one at the first persist
// (the learned state lost). A directory at the file's path stands for EACCES/EIO (the same read
// path; root reads a mode-000 file anyway).
TEST_F(StateTest, UnreadableStateIsReportedAndLeftAlone) {
  service::StateStore store(dir_.string(), config_.vehicle.name);
  fs::create_directories(store.path());
  const auto r = store.Load();
  EXPECT_FALSE(r.state);
  EXPECT_TRUE(r.unreadable);
  EXPECT_NE(r.message.find("exists but cannot be read"), std::string::npos) << r.message;
  EXPECT_TRUE(fs::is_directory(store.path())) << "left in place";
  // A missing file is not unreadable: start fresh.
  fs::remove(store.path());
  EXPECT_FALSE(store.Load().unreadable);
}

// Catches: temporary files of interrupted writes piling up in state_dir, or other files removed.
TEST_F(StateTest, TemporariesOfInterruptedWritesAreRemoved) {
  service::StateStore store(dir_.string(), config_.vehicle.name);
  store.Save(MakeState());
  const std::string name = fs::path(store.path()).filename().string();
  for (const std::string& t : {"." + name + ".tmp123.0", "." + name + ".tmp99999.7"}) WriteFileAtomically((dir_ / t).string(), "x");
  WriteFileAtomically((dir_ / "notes.txt").string(), "keep");
  WriteFileAtomically((dir_ / ".other.ndsid-state.tmp1.0").string(), "another vehicle's write");
  EXPECT_EQ(store.RemoveTemporaries(), 2);
  EXPECT_TRUE(fs::exists(store.path()));
  EXPECT_TRUE(fs::exists(dir_ / "notes.txt"));
  EXPECT_TRUE(fs::exists(dir_ / ".other.ndsid-state.tmp1.0"));
  EXPECT_TRUE(store.Load().state);
}

TEST_F(StateTest, StoreNeverLoadsAnotherVehiclesFileAndKeepsIt) {
  // Two names that map to the same file name: the header tells them apart.
  service::StateStore mine(dir_.string(), "car/1");
  service::StateStore theirs(dir_.string(), "car:1");
  ASSERT_EQ(mine.path(), theirs.path());
  service::LearnedState st = MakeState();
  st.vehicle = "car:1";
  theirs.Save(st);
  const auto r = mine.Load();
  EXPECT_FALSE(r.state);
  EXPECT_NE(r.message.find("car:1"), std::string::npos) << r.message;
  bool kept = false;
  for (const auto& e : fs::directory_iterator(dir_)) kept |= e.path().filename().string().find(".foreign-") != std::string::npos;
  EXPECT_TRUE(kept);
}

TEST_F(StateTest, RestoreDropsEstimateOutsideParameterBoxButKeepsStatistics) {
  const dbc::Database db = dbc::ParseDbcFile(config_.dbc);
  pipeline::Pipeline pipeline(config_, db);
  service::LearnedState st = MakeState();
  st.last_estimate->fit.params[model::kSteerRatio].value = -14.8;  // openpilot's poisoned cache
  std::string dropped;
  service::RestoreState(pipeline, config_, st, dropped);
  EXPECT_NE(dropped.find("is = -14.8 outside"), std::string::npos) << dropped;
  EXPECT_FALSE(pipeline.last_estimate());
  EXPECT_GT(pipeline.accumulator().gated_hours(), 0.05);
}

TEST_F(StateTest, RestoreKeepsPlausibleEstimateAndWaitsForNewData) {
  const dbc::Database db = dbc::ParseDbcFile(config_.dbc);
  pipeline::Pipeline pipeline(config_, db);
  const service::LearnedState st = MakeState();
  std::string dropped;
  service::RestoreState(pipeline, config_, st, dropped);
  EXPECT_EQ(dropped, "");
  ASSERT_TRUE(pipeline.last_estimate());
  EXPECT_EQ(pipeline.last_estimate()->fit.eg_rad_per_mps2, st.last_estimate->fit.eg_rad_per_mps2);
  EXPECT_EQ(pipeline.adequacy().history().size(), 1u);
  EXPECT_FALSE(pipeline.IdentificationDue());  // no new gated data since the restored fit
}

TEST_F(StateTest, RestoreRejectsNonFiniteStatisticsAsCorrupt) {
  const dbc::Database db = dbc::ParseDbcFile(config_.dbc);
  pipeline::Pipeline pipeline(config_, db);
  service::LearnedState st = MakeState();
  adequacy::Tracker tracker(config_.adequacy);
  tracker.Update(0.1, std::nan(""), 1e-5, stats::Coverage{});
  st.adequacy = tracker.Serialize();
  std::string dropped;
  try {
    service::RestoreState(pipeline, config_, st, dropped);
    FAIL();
  } catch (const service::StateFileError& e) {
    EXPECT_EQ(e.kind(), service::StateFileError::Kind::kCorrupt);
  }
  EXPECT_EQ(pipeline.accumulator().gated_hours(), 0.0);
}

}  // namespace
}  // namespace ndsid
