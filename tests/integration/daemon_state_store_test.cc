// The daemon's learned state: accumulator persistence, the state file's checks, quarantine,
// and the sanity checks on restore.
#include <gtest/gtest.h>

#include <bit>
#include <cmath>
#include <cstdio>
#include <cstring>
#include <filesystem>
#include <functional>
#include <limits>

#include "daemon_test_config.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/config/config.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/pipeline/estimate_codec.h"
#include "ndsid/stats/accumulator.h"
#include "state_store.h"

namespace ndsid {
namespace {

namespace fs = std::filesystem;

// The accumulator's learned state as the state file carries it (CBOR), and back.
std::string Bytes(const stats::Accumulator& a) { return ToCbor(a.ToJson()); }
void RestoreBytes(stats::Accumulator& a, const std::string& bytes) {
  a.FromJson(JsonIn(ParseCbor(bytes, "test state"), "state.accumulator"));
}

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
    st.accumulator = acc.ToJson();
    adequacy::Tracker tracker(config_.adequacy);
    tracker.Update(acc.gated_hours(), 2e-3, 1e-5, acc.coverage());
    st.adequacy = tracker.ToJson();
    pipeline::Estimate e;
    e.fit.valid = true;
    const double values[] = {1900, 2700, 78000, 122000, 1.15, 14.8};
    for (int i = 0; i < model::kNumParams; ++i) e.fit.params[i].value = values[i];
    e.fit.params[0].fixed = true;
    e.fit.eg_rad_per_mps2 = model::SelfSteerGradient(e.fit.AsParams(), config_.vehicle.wheelbase_m);
    e.fit.eg_deg_per_g = model::EgToDegPerG(e.fit.eg_rad_per_mps2);
    e.fit.reason = "line one\nline two";
    e.fit.yaw_rate_output = true;
    e.fit.rmse_train_yaw_radps = 0.0021;
    e.fit.noise_level_yaw_rate = 3.5e-6;
    e.fit.identifiability.weak.push_back({1e-4, "+0.71 m +0.71 Jz"});
    e.fit.identifiability.notes.push_back("m fixed from configuration");
    e.fit.drive_values.push_back({4, "load_ratio", 1.07, 0.01, false, true});
    e.fit.effect_params.push_back({"steer_offset", "rad", 0.0021, 1e-4, false, false});
    e.fit.correlation.assign(49, 0.25);
    e.plausibility.checks.push_back({"kinematics", adequacy::Verdict::kPassed, 1.01, 3600, "a_y = v r within 2 %"});
    e.plausibility.drives.push_back({3, 5'000'000'000, {{"steering_sign", adequacy::Verdict::kFailed, -0.8, 60, "flipped"}}});
    e.plausibility.drives_failed = 1;
    e.standstill.push_back({"gyro_offset_radps", -0.006, 0.0002, 4, 61.5});
    e.standstill_stops = 4;
    e.standstill_seconds = 61.5;
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
  RestoreBytes(b, Bytes(a));
  EXPECT_DOUBLE_EQ(b.gated_hours(), a.gated_hours());
  EXPECT_TRUE(b.steady_state() == a.steady_state());
  EXPECT_EQ(b.coverage().ToJson(), a.coverage().ToJson());
  ASSERT_EQ(b.window().size(), a.window().size());
  for (size_t i = 0; i < a.window().size(); ++i) {
    ASSERT_EQ(b.window()[i]->samples.size(), a.window()[i]->samples.size());
    EXPECT_EQ(0, std::memcmp(b.window()[i]->samples.data(), a.window()[i]->samples.data(),
                             a.window()[i]->samples.size() * sizeof(stats::SegmentSample)));
    EXPECT_EQ(b.window()[i]->drive_id, a.window()[i]->drive_id);
  }
  ASSERT_EQ(b.drives().size(), 2u);
  EXPECT_TRUE(b.drives()[1].used);
  EXPECT_EQ(Bytes(b), Bytes(a));
}

TEST(AccumulatorPersistence, SerializeMidDriveLeavesTheAccumulatorUnchanged) {
  const config::Config c = testing::DaemonTestConfig();
  stats::Accumulator a(c, c.sync.rate_hz), b(c, c.sync.rate_hz);
  FeedDrive(a, 0, 0, 60);
  FeedDrive(b, 0, 0, 60);
  const std::string mid = Bytes(a);  // drive still open, 1.2 km: not yet used
  EXPECT_FALSE(mid.empty());
  FeedDrive(a, 0, 0, 200, 60);
  FeedDrive(b, 0, 0, 200, 60);
  EXPECT_EQ(Bytes(a), Bytes(b));
  EXPECT_GT(a.gated_hours(), 0.05);
}

TEST(AccumulatorPersistence, OpenDriveShorterThanMinimumIsNotPersisted) {
  const config::Config c = testing::DaemonTestConfig();
  stats::Accumulator a(c, c.sync.rate_hz);
  FeedDrive(a, 0, 0, 60);  // 1.2 km < min_drive_km = 2
  stats::Accumulator b(c, c.sync.rate_hz);
  RestoreBytes(b, Bytes(a));
  EXPECT_EQ(b.gated_hours(), 0.0);
  EXPECT_TRUE(b.window().empty());
}

TEST(AccumulatorPersistence, DrivesAfterRestoreAreNumberedAfterRestoredOnes) {
  const config::Config c = testing::DaemonTestConfig();
  stats::Accumulator a(c, c.sync.rate_hz);
  FeedDrive(a, 0, 0, 150);
  FeedDrive(a, 1, 1'000'000'000'000, 150);
  stats::Accumulator b(c, c.sync.rate_hz);
  RestoreBytes(b, Bytes(a));
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
  nlohmann::json j = a.ToJson();
  std::vector<uint8_t>& samples = j["window"].back()["samples"].get_binary();
  const uint32_t nan = std::bit_cast<uint32_t>(std::nanf(""));
  for (size_t k = 0; k < 4; ++k) samples[samples.size() - 4 + k] = static_cast<uint8_t>(nan >> (8 * k));  // last a_x (LE)
  const std::string bytes = ToCbor(j);
  stats::Accumulator b(c, c.sync.rate_hz);
  FeedDrive(b, 0, 0, 150);
  const std::string before = Bytes(b);
  EXPECT_THROW(RestoreBytes(b, bytes), Error);
  EXPECT_EQ(Bytes(b), before);
  EXPECT_THROW(RestoreBytes(b, bytes.substr(0, bytes.size() / 2)), Error);
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
  EXPECT_EQ(back.last_estimate->fit.reason, "line one\nline two");  // text kept as it is
  // The whole estimate, field by field (fit, outputs, identifiability, steady state, adequacy,
  // plausibility, standstill evidence).
  EXPECT_EQ(pipeline::EstimateToJson(*back.last_estimate), pipeline::EstimateToJson(*st.last_estimate));
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

// Edits a state file's document and re-seals it (the header's size and checksum).
std::string EditDocument(const std::string& bytes, const std::function<void(nlohmann::json&)>& edit) {
  const size_t body = bytes.find("\n\n") + 2;
  nlohmann::json doc = ParseCbor(bytes.substr(body), "test");
  edit(doc);
  const std::string payload = ToCbor(doc);
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
  // No stops: an empty list.
  const service::LearnedState none = service::DecodeState(service::EncodeState(MakeState()), config_.vehicle.name);
  EXPECT_TRUE(none.stops.empty());
}

TEST_F(StateTest, MalformedStandstillStopIsCorruptAndLocated) {
  service::LearnedState st = MakeState();
  st.stops = TwoStops();
  const std::string bytes = service::EncodeState(st);
  const struct {
    std::function<void(nlohmann::json&)> edit;
    const char* says;
  } cases[] = {{[](nlohmann::json& d) { d["standstill"][1]["samples"] = 0; }, "state.standstill[1]: out of range"},
               {[](nlohmann::json& d) { d["standstill"][1]["seconds"] = "3"; }, "state.standstill[1].seconds: not a number"},
               {[](nlohmann::json& d) { d["standstill"][0]["drive"] = 0.5; }, "state.standstill[0].drive: not an integer"},
               {[](nlohmann::json& d) { d["standstill"] = nlohmann::json::object(); }, "state.standstill: not an array"},
               {[](nlohmann::json& d) { d["standstill"][1]["mean_yaw_rate_radps"] = true; },
                "state.standstill[1].mean_yaw_rate_radps: not a number"},
               {[](nlohmann::json& d) { d["standstill"][0].erase("t_start_ns"); }, "state.standstill[0].t_start_ns: missing"}};
  for (const auto& c : cases) {
    try {
      service::DecodeState(EditDocument(bytes, c.edit), config_.vehicle.name);
      ADD_FAILURE() << "no error for " << c.says;
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

// The incremental prior (docs/incremental.md) is learned state: it survives the file and reaches
// the pipeline; a damaged one is dropped alone (the next fit covers the whole window), the rest
// of the state is kept. Catches: a prior lost on restart, or a bad prior taking the state down.
TEST_F(StateTest, IncrementalPriorSurvivesAndADamagedOneIsDroppedAlone) {
  service::LearnedState st = MakeState();
  auto lw = std::make_shared<identify::LinearizedWindow>();
  lw->model = "single-track";
  lw->scale = {1900, 2700, 78000, 122000, 1.15, 14.8};
  lw->chunk_s = 60;
  lw->burn_in_s = 1.5;
  lw->updates_since_full = 4;
  identify::LinearizedSegment seg;
  seg.drive_id = 0;
  seg.t0_ns = 1'000'000;
  seg.samples = 3000;
  identify::LinearizedChunk c;
  c.theta = {1, 1.01, 0.99, 1, 1, 1.02};
  c.jtj.assign(36, 0.5);
  for (int i = 0; i < 6; ++i) c.jtj[i * 7] = 3.0 + i;
  c.score = {0.1, -0.2, 0.3, 0, 0, 0.01};
  c.rss = 12.5;
  c.rss_a_y = 12.5;
  c.n_a_y = 2925;
  c.acf_a_y.assign(251, 0.01);
  c.acf_a_y[0] = 12.5;
  seg.chunks = {c, c};
  lw->segments = {seg};
  st.linearized = lw;
  const std::string bytes = service::EncodeState(st);
  const service::LearnedState back = service::DecodeState(bytes, config_.vehicle.name);
  ASSERT_TRUE(back.linearized);
  EXPECT_EQ(back.linearized->chunks(), 2u);
  EXPECT_EQ(back.linearized->updates_since_full, 4);
  EXPECT_EQ(back.linearized->segments[0].chunks[1].jtj, c.jtj);
  EXPECT_EQ(back.linearized->segments[0].chunks[0].acf_a_y, c.acf_a_y);
  const dbc::Database db = dbc::ParseDbcFile(config_.dbc);
  pipeline::Pipeline pipeline(config_, db);
  std::string dropped;
  service::RestoreState(pipeline, config_, back, dropped);
  ASSERT_TRUE(pipeline.linearized());
  EXPECT_EQ(pipeline.linearized()->chunks(), 2u);
  EXPECT_EQ(service::CaptureState(pipeline, config_, 3).linearized, pipeline.linearized());

  const std::string damaged = EditDocument(bytes, [](nlohmann::json& d) { d["linearized"]["segments"][0]["chunks"][1]["rss"] = -1.0; });
  const service::LearnedState kept = service::DecodeState(damaged, config_.vehicle.name);
  EXPECT_FALSE(kept.linearized);
  ASSERT_TRUE(kept.last_estimate);
  EXPECT_EQ(kept.identifications, 3);
  EXPECT_EQ(kept.accumulator, st.accumulator);
  // A file without the member (older format 2) loads with no prior.
  const service::LearnedState older = service::DecodeState(EditDocument(bytes, [](nlohmann::json& d) { d.erase("linearized"); }),
                                                           config_.vehicle.name);
  EXPECT_FALSE(older.linearized);
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
  std::string v3 = bytes;
  v3.replace(0, 13, "NDSID-STATE 3");
  try {
    service::DecodeState(v3, config_.vehicle.name);
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
  st.adequacy = tracker.ToJson();
  std::string dropped;
  try {
    service::RestoreState(pipeline, config_, st, dropped);
    FAIL();
  } catch (const service::StateFileError& e) {
    EXPECT_EQ(e.kind(), service::StateFileError::Kind::kCorrupt);
  }
  EXPECT_EQ(pipeline.accumulator().gated_hours(), 0.0);
}

// ---- Migration: state files of format version 1 -------------------------------------------

// A number written on a "key value" line of a version 1 file (its meta and estimate sections
// are text), read independently of the migration code.
double KeyLine(const std::string& bytes, const std::string& key) {
  const size_t at = bytes.find("\n" + key + " ");
  EXPECT_NE(at, std::string::npos) << key;
  return at == std::string::npos ? std::nan("") : std::strtod(bytes.c_str() + at + key.size() + 2, nullptr);
}

// tests/integration/data/state_v1_whole.ndsid-state: written by ndsidd at 31fa977 (format 1)
// after the first 100 000 frames of replay/clean/drive.log.gz with config/example_vehicle.yaml.
// Catches: a version 1 file that no longer loads, or loads with any value changed.
TEST(StateMigration, Version1FileLoadsWithEveryValue) {
  const config::Config c = config::LoadConfig(NDSID_SOURCE_DIR "/config/example_vehicle.yaml");
  const std::string bytes = ReadWholeFile(NDSID_SOURCE_DIR "/tests/integration/data/state_v1_whole.ndsid-state");
  ASSERT_EQ(bytes.rfind("NDSID-STATE 1\n", 0), 0u);
  const service::LearnedState st = service::DecodeState(bytes, c.vehicle.name);
  // Values read straight from the file's text lines and its binary accumulator section.
  EXPECT_EQ(st.data_time_ns, 1709537668812740000);
  EXPECT_EQ(st.identifications, static_cast<int32_t>(KeyLine(bytes, "identifications")));
  ASSERT_TRUE(st.last_estimate);
  EXPECT_EQ(st.last_estimate->fit.eg_rad_per_mps2, KeyLine(bytes, "fit.eg"));
  EXPECT_EQ(st.last_estimate->fit.eg_se_rad_per_mps2, KeyLine(bytes, "fit.eg_se"));
  EXPECT_EQ(st.last_estimate->fit.rmse_train_mps2, KeyLine(bytes, "fit.rmse_train"));
  EXPECT_EQ(st.last_estimate->fit.params[1].value, KeyLine(bytes, "fit.param.Jz.value"));
  EXPECT_EQ(st.last_estimate->steady_state.eg_rad_per_mps2, KeyLine(bytes, "steady.eg"));
  const size_t acc = bytes.find("ACC2");
  ASSERT_NE(acc, std::string::npos);
  double gated_s = 0;
  std::memcpy(&gated_s, bytes.data() + acc + 4, sizeof gated_s);  // the layout's first value
  // What the version 1 reader (ndsidd --show-state at 31fa977) printed for this file.
  const dbc::Database db = dbc::ParseDbcFile(c.dbc);
  pipeline::Pipeline pipeline(c, db);
  std::string dropped;
  service::RestoreState(pipeline, c, st, dropped);
  EXPECT_EQ(dropped, "");
  EXPECT_EQ(pipeline.accumulator().gated_hours(), gated_s / 3600.0);
  EXPECT_NEAR(pipeline.accumulator().gated_hours(), 0.064533, 5e-7);
  ASSERT_EQ(pipeline.accumulator().drives().size(), 1u);
  EXPECT_TRUE(pipeline.accumulator().drives()[0].used);
  EXPECT_EQ(pipeline.accumulator().window().size(), 4u);
  EXPECT_NEAR(pipeline.accumulator().window_hours(), 0.0644, 5e-5);
  ASSERT_EQ(st.stops.size(), 2u);
  EXPECT_NEAR(st.stops[0].seconds + st.stops[1].seconds, 19.33, 5e-3);
  EXPECT_EQ(pipeline.adequacy().history().size(), 2u);
  ASSERT_TRUE(pipeline.last_estimate());
  EXPECT_EQ(pipeline.last_estimate()->fit.eg_rad_per_mps2, st.last_estimate->fit.eg_rad_per_mps2);
  // Saved again it is a version 2 file that reads back to the same document.
  const std::string v2 = service::EncodeState(service::CaptureState(pipeline, c, st.identifications));
  ASSERT_EQ(v2.rfind("NDSID-STATE 2\n", 0), 0u);
  const service::LearnedState again = service::DecodeState(v2, c.vehicle.name);
  EXPECT_EQ(again.accumulator, pipeline.accumulator().ToJson());
  EXPECT_EQ(again.adequacy, pipeline.adequacy().ToJson());
  EXPECT_EQ(pipeline::EstimateToJson(*again.last_estimate), pipeline::EstimateToJson(*st.last_estimate));
  EXPECT_EQ(pipeline::StopsToJson(again.stops), pipeline::StopsToJson(st.stops));
  std::printf("version 1: %zu bytes; version 2: %zu bytes\n", bytes.size(), v2.size());
}

// tests/integration/data/state_v1_open_drive.ndsid-state: a version 1 file from ndsidd stopped in the
// middle of a drive (held-back segments and the open segment, tag ACC2).
// Catches: the drive in progress lost when a version 1 file is migrated.
TEST(StateMigration, Version1OpenDriveSurvives) {
  const config::Config c = config::LoadConfig(NDSID_SOURCE_DIR "/config/example_vehicle.yaml");
  const std::string bytes = ReadWholeFile(NDSID_SOURCE_DIR "/tests/integration/data/state_v1_open_drive.ndsid-state");
  const service::LearnedState st = service::DecodeState(bytes, c.vehicle.name);
  const nlohmann::json& open = st.accumulator.at("open_drive");
  ASSERT_TRUE(open.is_object());
  EXPECT_FALSE(open.at("used").get<bool>());
  EXPECT_GT(open.at("pending_samples").get<uint64_t>(), 0u);  // held back: the drive is short of min_drive_km
  ASSERT_TRUE(open.at("open_segment").is_object());
  EXPECT_GT(open.at("open_segment").at("segment").at("samples").get_binary().size(), 0u);
  const dbc::Database db = dbc::ParseDbcFile(c.dbc);
  pipeline::Pipeline pipeline(c, db);
  std::string dropped;
  service::RestoreState(pipeline, c, st, dropped);
  EXPECT_EQ(pipeline.accumulator().ToJson(), st.accumulator);
  EXPECT_EQ(pipeline.accumulator().drives().size(), 1u);
}

}  // namespace
}  // namespace ndsid
