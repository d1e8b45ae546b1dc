// The simulated bus: the log decodes back through our CandumpReader + Decoder to the simulated
// measured signals within the DBC quantisation; cycle times, counters, checksums, multiplexed
// pages, key-off gaps; identical bytes for the same seed.
#include "ndsid/sim/candump_writer.h"

#include <gtest/gtest.h>

#include <algorithm>
#include <cmath>
#include <cstdio>
#include <filesystem>
#include <functional>
#include <map>

#include "ndsid/can/candump_reader.h"
#include "ndsid/common/atomic_file.h"
#include "ndsid/common/error.h"
#include "ndsid/config/simulation_config.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/decoder.h"

namespace ndsid::sim {
namespace {

namespace fs = std::filesystem;
constexpr double kDeg = 180.0 / M_PI;

fs::path TempDir(const std::string& name) {
  const fs::path dir = fs::path(NDSID_BINARY_DIR) / "test_tmp" / name;
  fs::create_directories(dir);
  return dir;
}

std::vector<can::CanFrame> ReadAll(const std::string& path) {
  can::CandumpReader reader(path);
  std::vector<can::CanFrame> frames;
  std::vector<can::CanFrame> buf(4096);
  for (;;) {
    const auto r = reader.Read(buf, 0);
    frames.insert(frames.end(), buf.begin(), buf.begin() + static_cast<std::ptrdiff_t>(r.count));
    if (r.state == can::SourceState::kEnd) break;
  }
  EXPECT_EQ(reader.counters().malformed, 0u);
  return frames;
}

// One drive of seed 4 with the simulation YAML `yaml`.
config::SimulationConfig OneDrive(const std::string& yaml) {
  config::SimulationConfig cfg = config::ParseSimulationConfig(yaml, "bus.yaml");
  cfg.duration.drives = 1;
  cfg.seed = 4;
  return cfg;
}

class CandumpWriterTest : public ::testing::Test {
 protected:
  void SetUp() override {
    db_ = dbc::ParseDbcFile(std::string(NDSID_SOURCE_DIR) + "/dbc/ndsid_example.dbc");
    cfg_.duration.drives = 2;
    cfg_.seed = 4;
    result_ = Simulate(cfg_);
  }
  dbc::Database db_;
  config::SimulationConfig cfg_;
  SimulationResult result_;
};

TEST_F(CandumpWriterTest, LogDecodesBackToSimulatedSignalsWithinQuantisation) {
  // Catches encoder/decoder disagreements (byte order, sign, factor), frames paired with the
  // wrong sample, and ISO sign flips between the simulator and the bus.
  const std::string path = (TempDir("roundtrip") / "drive.log.gz").string();
  WriteCandumpLog(result_, db_, path);
  const auto frames = ReadAll(path);
  FrameEncoder encoder(db_, cfg_);
  std::map<std::string, int64_t> tick_offset;
  for (const auto& m : encoder.messages()) tick_offset[m.name] = m.phase_us / 10000;

  dbc::Decoder decoder(db_);
  std::vector<dbc::DecodedValue> values(decoder.max_signals_per_message());
  struct Check {
    const char* message;
    const char* signal;
    double lsb;
    std::function<double(const DriveSeries&, size_t)> expected;
  };
  const std::vector<Check> checks = {
      {"STEERING_SENSOR", "SteeringWheelAngle", 0.1, [](const DriveSeries& s, size_t i) { return s.steer_sw_meas_rad[i] * kDeg; }},
      {"ESP_DYNAMICS", "LateralAcceleration", 0.01, [](const DriveSeries& s, size_t i) { return s.a_y_meas_mps2[i]; }},
      {"ESP_DYNAMICS", "YawRate", 0.01, [](const DriveSeries& s, size_t i) { return s.yaw_rate_meas_radps[i] * kDeg; }},
      {"ESP_DYNAMICS", "LongitudinalAcceleration", 0.01, [](const DriveSeries& s, size_t i) { return s.a_x_meas_mps2[i]; }},
      {"VEHICLE_SPEED", "VehicleSpeed", 1.0 / 256.0, [](const DriveSeries& s, size_t i) { return s.speed_meas_mps[i] * 3.6; }},
      {"WHEEL_SPEEDS", "WheelSpeedRL", 0.01, [](const DriveSeries& s, size_t i) { return s.wheel_speed_meas_mps[2][i] * 3.6; }},
      {"VEHICLE_STATUS", "ReverseGear", 1.0, [](const DriveSeries& s, size_t i) { return s.gear[i] == 1 ? 1.0 : 0.0; }},
  };
  std::map<std::string, double> max_err;
  std::map<std::string, size_t> compared;
  // Frames of each drive: between its start and the next drive's start.
  size_t f = 0;
  for (size_t d = 0; d < result_.drives.size(); ++d) {
    const auto& drive = result_.drives[d];
    const auto& s = drive.series;
    const int64_t end_ns = drive.start_epoch_ns + static_cast<int64_t>(s.size()) * 10000000LL;
    std::map<uint32_t, int64_t> count;  // frames seen per id in this drive
    for (; f < frames.size() && frames[f].timestamp_ns < end_ns; ++f) {
      const auto& fr = frames[f];
      ASSERT_GE(fr.timestamp_ns, drive.start_epoch_ns);
      const dbc::Message* m = db_.FindMessage(fr.id, fr.extended());
      ASSERT_NE(m, nullptr);
      const int64_t k = count[fr.id]++;
      const size_t i = static_cast<size_t>(tick_offset[m->name] + k * static_cast<int64_t>(*m->cycle_time_ms / 10.0));
      ASSERT_LT(i, s.size());
      size_t n = 0;
      ASSERT_EQ(decoder.Decode(fr, values, n), dbc::DecodeVerdict::kDecoded);
      for (const auto& c : checks) {
        if (m->name != c.message) continue;
        for (size_t v = 0; v < n; ++v) {
          if (decoder.signals()[static_cast<size_t>(values[v].signal_index)].signal->name != c.signal) continue;
          if (!s.valid[i] && std::string(c.message) != "VEHICLE_SPEED") continue;
          const double err = std::fabs(values[v].value - c.expected(s, i));
          ASSERT_LE(err, 0.5 * c.lsb + 1e-9) << c.signal << " drive " << d << " sample " << i;
          max_err[c.signal] = std::max(max_err[c.signal], err);
          ++compared[c.signal];
        }
      }
    }
  }
  EXPECT_EQ(f, frames.size());
  for (const auto& c : checks) EXPECT_GT(compared[c.signal], 1000u) << c.signal;
}

TEST_F(CandumpWriterTest, CyclesCountersChecksumsPagesAndKeyOffGaps) {
  // Catches wrong cycle times, counters that do not roll, bad XOR checksums, stuck mux pages,
  // and frames in the key-off gap.
  const std::string path = (TempDir("bus") / "drive.log").string();
  WriteCandumpLog(result_, db_, path);
  const auto frames = ReadAll(path);
  std::map<uint32_t, std::vector<int64_t>> times;
  std::map<uint32_t, std::vector<uint8_t>> counters;
  std::vector<int> pages;
  int64_t prev = 0;
  const int64_t drive1 = result_.drives[1].start_epoch_ns;
  const int64_t drive0_end = result_.drives[0].start_epoch_ns + static_cast<int64_t>(result_.drives[0].series.size()) * 10000000LL;
  for (const auto& fr : frames) {
    EXPECT_GE(fr.timestamp_ns, prev) << "time order";
    prev = fr.timestamp_ns;
    EXPECT_FALSE(fr.timestamp_ns > drive0_end + 10000000LL && fr.timestamp_ns < drive1) << "frame in key-off gap";
    if (fr.timestamp_ns >= drive1) continue;  // drive 0 only below
    times[fr.id].push_back(fr.timestamp_ns);
    if (fr.id == 0x0B0 || fr.id == 0x0C0) {
      uint8_t x = 0;
      for (int b = 0; b < 7; ++b) x ^= fr.data[static_cast<size_t>(b)];
      ASSERT_EQ(x, fr.data[7]) << "checksum id " << fr.id;
      counters[fr.id].push_back(fr.data[6] & 0x0F);  // both counters: byte 6, bits 0..3
    }
    if (fr.id == 0x3E0) pages.push_back(fr.data[0] & 0x0F);
  }
  for (const auto& m : db_.messages) {
    const auto& t = times[m.id];
    ASSERT_GT(t.size(), 10u) << m.name;
    std::vector<int64_t> dt;
    for (size_t i = 1; i < t.size(); ++i) dt.push_back(t[i] - t[i - 1]);
    std::nth_element(dt.begin(), dt.begin() + static_cast<std::ptrdiff_t>(dt.size() / 2), dt.end());
    EXPECT_NEAR(static_cast<double>(dt[dt.size() / 2]) / 1e6, *m.cycle_time_ms, 0.2) << m.name;
  }
  for (const auto& [id, c] : counters)
    for (size_t i = 1; i < c.size(); ++i) ASSERT_EQ(c[i], (c[i - 1] + 1) % 16) << "counter id " << id;
  for (size_t i = 0; i < pages.size(); ++i) ASSERT_EQ(pages[i], static_cast<int>(i % 3));
  EXPECT_GT(drive1 - drive0_end, static_cast<int64_t>(0.5 * 3600e9));
}

TEST_F(CandumpWriterTest, SameSeedWritesIdenticalBytes) {
  // Catches non-determinism in the log (jitter, phases, gzip header time stamps).
  const auto dir = TempDir("determinism");
  WriteCandumpLog(result_, db_, (dir / "a.log.gz").string());
  WriteCandumpLog(Simulate(cfg_), db_, (dir / "b.log.gz").string());
  const std::string a = ReadWholeFile((dir / "a.log.gz").string()), b = ReadWholeFile((dir / "b.log.gz").string());
  EXPECT_GT(a.size(), 100000u);
  EXPECT_TRUE(a == b);
}

// bus.signals (docs/simulator.md, "Encoding into another DBC"): the mapped signals carry the
// drive in their DBC unit (here mph and rad), a message without GenMsgCycleTime is sent at
// signal_cycle_ms, every other signal is 0. Catches a mapping ignored or a unit not converted.
TEST_F(CandumpWriterTest, BusSignalsMapQuantitiesOntoAnotherDbcInItsUnits) {
  const std::string text =
      "BO_ 100 MOTION: 8 X\n"
      " SG_ Spd : 0|16@1+ (0.01,0) [0|600] \"mph\" X\n"
      " SG_ Steer : 16|16@1- (0.001,0) [-32|32] \"rad\" X\n"
      " SG_ Other : 32|16@1- (0.01,0) [-300|300] \"deg\" X\n";
  const dbc::Database other = dbc::ParseDbcText(text, "other.dbc");
  const config::SimulationConfig cfg =
      OneDrive("bus:\n  signals:\n    vehicle_speed: MOTION.Spd\n    steering_wheel_angle: MOTION.Steer\n");
  const SimulationResult sim = Simulate(cfg);
  FrameEncoder encoder(other, cfg);
  ASSERT_EQ(encoder.messages().size(), 1u);
  EXPECT_DOUBLE_EQ(encoder.messages()[0].cycle_ms, 10.0);
  const auto frames = encoder.EncodeDrive(sim.drives[0]);
  const dbc::Decoder decoder(other);
  std::vector<dbc::DecodedValue> out(decoder.max_signals_per_message());
  const auto& s = sim.drives[0].series;
  ASSERT_EQ(frames.size(), s.size());  // 100 Hz, one frame per sample
  double max_speed_err = 0, max_steer_err = 0, max_other = 0;
  for (size_t i = 0; i < frames.size(); ++i) {
    size_t n = 0;
    decoder.Decode(frames[i], out, n);
    ASSERT_EQ(n, 3u);
    const double valid = s.valid[i] ? 1.0 : 0.0;
    max_speed_err = std::max(max_speed_err, std::fabs(out[0].value - s.speed_meas_mps[i] / 0.44704));
    max_steer_err = std::max(max_steer_err, std::fabs(out[1].value - valid * s.steer_sw_meas_rad[i]));
    max_other = std::max(max_other, std::fabs(out[2].value));
  }
  EXPECT_LT(max_speed_err, 0.006);   // mph, quantisation 0.01
  EXPECT_LT(max_steer_err, 0.0006);  // rad, quantisation 0.001
  EXPECT_EQ(max_other, 0.0);
}

TEST_F(CandumpWriterTest, BusSignalMissingFromTheDbcIsAConfigError) {
  config::SimulationConfig cfg =
      config::ParseSimulationConfig("bus:\n  signals:\n    yaw_rate: ESP_DYNAMICS.NoSuchSignal\n", "bus.yaml");
  try {
    FrameEncoder encoder(db_, cfg);
    FAIL() << "no error";
  } catch (const ConfigError& e) {
    EXPECT_NE(std::string(e.what()).find("bus.signals.yaw_rate: "), std::string::npos) << e.what();
    EXPECT_NE(std::string(e.what()).find("ESP_DYNAMICS.NoSuchSignal"), std::string::npos) << e.what();
  }
  EXPECT_THROW(config::ParseSimulationConfig("bus:\n  signals:\n    yaw_rate: NoDot\n", "bus.yaml"), ConfigError);
  EXPECT_THROW(config::ParseSimulationConfig("bus:\n  signals:\n    yaw: A.B\n", "bus.yaml"), ConfigError);
}

// bus.message_cycle_ms and bus.frame_loss_pct (docs/simulator.md, "Low and irregular rates"):
// the message at its own cycle, a share of its frames lost near the stated one (intervals of
// whole cycles), the ECU's counter advancing over each loss. Catches an override ignored, losses
// that reorder or retime frames, a counter that hides the gap.
TEST_F(CandumpWriterTest, MessageCyclesAndFrameLossGiveIrregularIntervals) {
  const config::SimulationConfig cfg = OneDrive("bus:\n  message_cycle_ms: {ESP_DYNAMICS: 80}\n  frame_loss_pct: 20\n");
  const SimulationResult r = Simulate(cfg);
  FrameEncoder encoder(db_, cfg);
  std::vector<int64_t> t;
  std::vector<uint8_t> counter;
  for (const can::CanFrame& f : encoder.EncodeDrive(r.drives[0])) {
    if (f.id != 0x0C0) continue;
    t.push_back(f.timestamp_ns);
    counter.push_back(f.data[6] & 0x0F);
  }
  const double expected = static_cast<double>(r.drives[0].series.size()) / 8.0;  // 100 Hz samples / 8 ticks
  ASSERT_GT(t.size(), 100u);
  const double kept = static_cast<double>(t.size()) / expected;
  std::printf("ESP_DYNAMICS at 80 ms with 20 %% loss: %.3f of the frames kept\n", kept);
  EXPECT_NEAR(kept, 0.8, 0.03);
  size_t gaps = 0;
  for (size_t i = 1; i < t.size(); ++i) {
    const int64_t cycles = std::llround(static_cast<double>(t[i] - t[i - 1]) / 80e6);
    ASSERT_GE(cycles, 1);
    EXPECT_NEAR(static_cast<double>(t[i] - t[i - 1]) / 1e6, 80.0 * static_cast<double>(cycles), 0.5);
    ASSERT_EQ(counter[i], (counter[i - 1] + cycles) % 16) << "counter over a gap of " << cycles << " cycles";
    gaps += cycles > 1;
  }
  EXPECT_GT(gaps, t.size() / 10);
  config::SimulationConfig unknown = config::ParseSimulationConfig("bus:\n  message_cycle_ms: {NO_SUCH: 80}\n", "bus.yaml");
  EXPECT_THROW(FrameEncoder(db_, unknown), ConfigError);
  EXPECT_THROW(config::ParseSimulationConfig("bus:\n  message_cycle_ms: {ESP_DYNAMICS: 5}\n", "bus.yaml"), ConfigError);
  EXPECT_THROW(config::ParseSimulationConfig("bus:\n  frame_loss_pct: 60\n", "bus.yaml"), ConfigError);
}

}  // namespace
}  // namespace ndsid::sim
