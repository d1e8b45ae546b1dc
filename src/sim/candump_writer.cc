#include "ndsid/sim/candump_writer.h"

#include <zlib.h>

#include <algorithm>
#include <cctype>
#include <cmath>
#include <cstdio>
#include <map>

#include "ndsid/can/candump_reader.h"
#include "ndsid/common/error.h"
#include "ndsid/dbc/encoder.h"
#include "ndsid/sim/random.h"

namespace ndsid::sim {

namespace {

constexpr double kRadToDeg = 180.0 / M_PI;
constexpr double kMpsToKph = 3.6;
constexpr int64_t kTick_us = 10000;  // 100 Hz sample grid = the fastest cycle

// What a signal carries, resolved once by name.
enum class Quantity {
  kZero, kSteerAngle, kSteerRate, kValid, kLatAccel, kLongAccel, kYawRate, kEsp, kWheelFL, kWheelFR, kWheelRL,
  kWheelRR, kSpeed, kBrake, kEngineSpeed, kEngineTorque, kPedal, kGear, kReverse, kOdometer, kAmbient,
  kBatteryVoltage, kBatteryCurrent, kCabinTemp, kFan, kAc, kCounter, kChecksum, kMultiplexor,
  kSteerAngleMagnitude, kSteerAngleNegative, kYawRateMagnitude, kYawRateNegative  // bus.signals only
};

Quantity QuantityFor(const std::string& name) {
  static const std::map<std::string, Quantity> table = {
      {"SteeringWheelAngle", Quantity::kSteerAngle}, {"SteeringWheelRate", Quantity::kSteerRate},
      {"SteeringAngleValid", Quantity::kValid},      {"DynamicsValid", Quantity::kValid},
      {"LateralAcceleration", Quantity::kLatAccel},  {"LongitudinalAcceleration", Quantity::kLongAccel},
      {"YawRate", Quantity::kYawRate},               {"EspIntervention", Quantity::kEsp},
      {"WheelSpeedFL", Quantity::kWheelFL},          {"WheelSpeedFR", Quantity::kWheelFR},
      {"WheelSpeedRL", Quantity::kWheelRL},          {"WheelSpeedRR", Quantity::kWheelRR},
      {"VehicleSpeed", Quantity::kSpeed},            {"BrakeSwitch", Quantity::kBrake},
      {"EngineSpeed", Quantity::kEngineSpeed},       {"EngineTorque", Quantity::kEngineTorque},
      {"AcceleratorPedal", Quantity::kPedal},        {"GearPosition", Quantity::kGear},
      {"ReverseGear", Quantity::kReverse},           {"Odometer", Quantity::kOdometer},
      {"AmbientTemperature", Quantity::kAmbient},    {"BatteryVoltage", Quantity::kBatteryVoltage},
      {"BatteryCurrent", Quantity::kBatteryCurrent}, {"CabinTemperature", Quantity::kCabinTemp},
      {"FanLevel", Quantity::kFan},                  {"AcCompressorOn", Quantity::kAc},
  };
  const auto it = table.find(name);
  if (it != table.end()) return it->second;
  if (name.size() >= 7 && name.compare(name.size() - 7, 7, "Counter") == 0) return Quantity::kCounter;
  if (name.size() >= 8 && name.compare(name.size() - 8, 8, "Checksum") == 0) return Quantity::kChecksum;
  return Quantity::kZero;
}

// bus.signals: quantity name -> Quantity.
Quantity QuantityForBusName(const std::string& name) {
  static const std::map<std::string, Quantity> table = {
      {"steering_wheel_angle", Quantity::kSteerAngle}, {"steering_wheel_rate", Quantity::kSteerRate},
      {"vehicle_speed", Quantity::kSpeed},             {"lateral_acceleration", Quantity::kLatAccel},
      {"longitudinal_acceleration", Quantity::kLongAccel}, {"yaw_rate", Quantity::kYawRate},
      {"wheel_speed_fl", Quantity::kWheelFL},          {"wheel_speed_fr", Quantity::kWheelFR},
      {"wheel_speed_rl", Quantity::kWheelRL},          {"wheel_speed_rr", Quantity::kWheelRR},
      {"valid", Quantity::kValid},                     {"esc_intervention", Quantity::kEsp},
      {"reverse_gear", Quantity::kReverse},
      {"steering_wheel_angle_magnitude", Quantity::kSteerAngleMagnitude},
      {"steering_wheel_angle_negative", Quantity::kSteerAngleNegative},
      {"yaw_rate_magnitude", Quantity::kYawRateMagnitude},
      {"yaw_rate_negative", Quantity::kYawRateNegative}};
  const auto it = table.find(name);
  return it == table.end() ? Quantity::kZero : it->second;
}

// Factor from the quantity's own unit (deg, deg/s, km/h, m/s^2) to the mapped signal's DBC unit,
// when that is a unit of the same kind; else 1.
double UnitFactor(Quantity q, std::string unit) {
  for (char& c : unit) c = static_cast<char>(std::tolower(static_cast<unsigned char>(c)));
  switch (q) {
    case Quantity::kSteerAngle:
    case Quantity::kSteerAngleMagnitude: return unit == "rad" ? M_PI / 180.0 : 1.0;
    case Quantity::kSteerRate:
    case Quantity::kYawRate:
    case Quantity::kYawRateMagnitude: return unit == "rad/s" ? M_PI / 180.0 : 1.0;
    case Quantity::kSpeed:
    case Quantity::kWheelFL: case Quantity::kWheelFR: case Quantity::kWheelRL: case Quantity::kWheelRR:
      return unit == "m/s" ? 1.0 / 3.6 : unit == "mph" ? 1.0 / 1.609344 : 1.0;
    case Quantity::kLatAccel:
    case Quantity::kLongAccel: return unit == "g" || unit == "unit_forceofgravi" ? 1.0 / 9.80665 : 1.0;
    default: return 1.0;
  }
}

struct SignalPlan {
  const dbc::Signal* signal;
  Quantity quantity;
  double scale = 1.0;  // quantity unit -> the signal's DBC unit (bus.signals only)
};

struct MessagePlan {
  const dbc::Message* message;
  int64_t cycle_ticks;   // cycle in 10 ms ticks
  int64_t tick_offset;   // which tick of the cycle it is sent in
  int64_t phase_us;      // offset inside the 10 ms tick
  std::vector<SignalPlan> signals;
  std::vector<uint64_t> pages;  // multiplexor values, in turn
  uint64_t counter = 0;
};

}  // namespace

struct FrameEncoder::Impl {
  const dbc::Database& db;
  const config::SimulationConfig& cfg;
  std::vector<MessagePlan> plans;
};

FrameEncoder::FrameEncoder(const dbc::Database& db, const config::SimulationConfig& cfg)
    : impl_(std::make_unique<Impl>(Impl{db, cfg, {}})) {
  Rng rng(MixSeed(cfg.seed, 7));
  // Distinct phases inside the 10 ms tick, >= 0.4 ms apart, so jitter (< 0.15 ms) never reorders.
  std::vector<int64_t> slots;
  for (int64_t p = 300; p <= 9500; p += 400) slots.push_back(p);
  for (size_t i = slots.size(); i > 1; --i) std::swap(slots[i - 1], slots[static_cast<size_t>(rng.Index(static_cast<int>(i)))]);
  size_t slot = 0;
  // bus.signals: "MESSAGE.SIGNAL" -> quantity; then only those carry the drive.
  std::map<std::pair<std::string, std::string>, Quantity> mapped;
  for (const auto& [name, ref] : cfg.bus.signals) {
    const auto dot = ref.find('.');
    const std::string msg = ref.substr(0, dot), sig = dot == std::string::npos ? "" : ref.substr(dot + 1);
    const dbc::Message* m = db.FindMessage(msg);
    if (m == nullptr || m->FindSignal(sig) == nullptr)
      throw ConfigError(cfg.source_file + ": bus.signals." + name + ": " + db.file + " has no signal " + ref);
    mapped[{msg, sig}] = QuantityForBusName(name);
  }
  auto carries_mapped = [&](const dbc::Message& m) {
    for (const auto& s : m.signals)
      if (mapped.count({m.name, s.name})) return true;
    return false;
  };
  const bool by_map = !mapped.empty();
  for (const auto& [name, ms] : cfg.bus.message_cycle_ms)
    if (db.FindMessage(name) == nullptr)
      throw ConfigError(cfg.source_file + ": bus.message_cycle_ms." + name + ": " + db.file + " has no message " + name);
  for (const auto& m : db.messages) {
    const auto own = cfg.bus.message_cycle_ms.find(m.name);
    double cycle_ms = own != cfg.bus.message_cycle_ms.end()       ? own->second
                      : m.cycle_time_ms && *m.cycle_time_ms > 0.0 ? *m.cycle_time_ms
                      : by_map && carries_mapped(m)               ? cfg.bus.signal_cycle_ms
                                                                  : cfg.bus.default_cycle_ms;
    if (cycle_ms <= 0.0) continue;
    MessagePlan plan{&m, std::max<int64_t>(1, std::llround(cycle_ms / 10.0)), 0, 0, {}, {}, 0};
    plan.tick_offset = rng.Index(static_cast<int>(plan.cycle_ticks));
    plan.phase_us = slots[slot++ % slots.size()];
    for (const auto& s : m.signals) {
      Quantity q = s.mux_role == dbc::MuxRole::kMultiplexor ? Quantity::kMultiplexor : QuantityFor(s.name);
      double scale = 1.0;
      if (by_map && q != Quantity::kMultiplexor) {
        const auto it = mapped.find({m.name, s.name});
        if (it != mapped.end()) q = it->second, scale = UnitFactor(q, s.unit);
        else if (q != Quantity::kCounter && q != Quantity::kChecksum) q = Quantity::kZero;
      }
      plan.signals.push_back({&s, q, scale});
      if (s.mux_role == dbc::MuxRole::kMultiplexed &&
          std::find(plan.pages.begin(), plan.pages.end(), s.mux_value) == plan.pages.end())
        plan.pages.push_back(s.mux_value);
    }
    std::sort(plan.pages.begin(), plan.pages.end());
    impl_->plans.push_back(std::move(plan));
  }
  if (impl_->plans.empty())
    throw ConfigError(db.file + ": no message has a GenMsgCycleTime; the simulator has nothing to send");
}

FrameEncoder::~FrameEncoder() = default;

std::vector<FrameEncoder::MessageInfo> FrameEncoder::messages() const {
  std::vector<MessageInfo> out;
  for (const auto& p : impl_->plans)
    out.push_back({p.message->name, static_cast<double>(p.cycle_ticks) * 10.0, p.tick_offset * kTick_us + p.phase_us});
  return out;
}

std::vector<can::CanFrame> FrameEncoder::EncodeDrive(const DriveResult& drive) {
  std::vector<can::CanFrame> frames;
  EncodeDrive(drive, [&](const can::CanFrame& f) { frames.push_back(f); });
  return frames;
}

void FrameEncoder::EncodeDriveImpl(const DriveResult& drive, void (*emit)(void*, const can::CanFrame&), void* ctx) {
  const DriveSeries& s = drive.series;
  const size_t n = s.size();
  Rng jitter(MixSeed(impl_->cfg.seed, 50000 + static_cast<uint64_t>(drive.index)));
  Rng loss(MixSeed(impl_->cfg.seed, 60000 + static_cast<uint64_t>(drive.index)));
  const double loss_p = impl_->cfg.bus.frame_loss_pct / 100.0;
  const int64_t start_us = drive.start_epoch_ns / 1000;
  double odometer_km = drive.odometer_start_km;
  const double mass = drive.params.m;
  struct Pending {
    int64_t ts_us;
    MessagePlan* plan;
  };
  std::vector<Pending> due;
  for (auto& p : impl_->plans) p.counter = 0;  // ECUs start their counters at key-on
  for (size_t i = 0; i < n; ++i) {  // tick i = sample i (100 Hz)
    odometer_km += s.speed_meas_mps[i] / kOutputRate_hz / 1000.0;
    due.clear();
    for (auto& p : impl_->plans) {
      if ((static_cast<int64_t>(i) - p.tick_offset) % p.cycle_ticks != 0 || static_cast<int64_t>(i) < p.tick_offset) continue;
      const double j = std::clamp(jitter.Normal(0.0, 50.0), -150.0, 150.0);
      due.push_back({start_us + static_cast<int64_t>(i) * kTick_us + p.phase_us + std::llround(j), &p});
    }
    std::sort(due.begin(), due.end(), [](const Pending& a, const Pending& b) { return a.ts_us < b.ts_us; });
    const double t = s.t_s[i];
    const double v = std::fabs(s.speed_mps[i]);
    const bool valid = s.valid[i] != 0;
    for (const Pending& d : due) {
      MessagePlan& p = *d.plan;
      if (loss_p > 0 && loss.Bernoulli(loss_p)) {  // lost on the way to the logger: the ECU's counter moves on
        ++p.counter;
        continue;
      }
      can::CanFrame f;
      f.timestamp_ns = d.ts_us * 1000;
      f.id = p.message->id;
      f.flags = p.message->extended ? can::kFlagExtended : 0;
      f.len = static_cast<uint8_t>(std::min<uint32_t>(p.message->length, 8));
      std::span<uint8_t> payload(f.data.data(), f.len);
      const uint64_t page = p.pages.empty() ? 0 : p.pages[p.counter % p.pages.size()];
      const dbc::Signal* checksum = nullptr;
      for (const SignalPlan& sp : p.signals) {
        const dbc::Signal& sig = *sp.signal;
        if (sig.mux_role == dbc::MuxRole::kMultiplexed && sig.mux_value != page) continue;
        if (dbc::RequiredBytes(sig) > f.len) continue;  // beyond the 8 bytes a classic frame carries
        double x = 0.0;
        switch (sp.quantity) {
          case Quantity::kZero: x = std::clamp(0.0, sig.minimum, std::max(sig.minimum, sig.maximum)); break;
          case Quantity::kMultiplexor: x = static_cast<double>(page); break;
          case Quantity::kSteerAngle: x = valid ? s.steer_sw_meas_rad[i] * kRadToDeg : 0.0; break;
          case Quantity::kSteerRate: x = valid ? s.steer_rate_meas_radps[i] * kRadToDeg : 0.0; break;
          case Quantity::kSteerAngleMagnitude: x = valid ? std::fabs(s.steer_sw_meas_rad[i]) * kRadToDeg : 0.0; break;
          case Quantity::kSteerAngleNegative: x = valid && s.steer_sw_meas_rad[i] < 0 ? 1 : 0; break;
          case Quantity::kYawRateMagnitude: x = valid ? std::fabs(s.yaw_rate_meas_radps[i]) * kRadToDeg : 0.0; break;
          case Quantity::kYawRateNegative: x = valid && s.yaw_rate_meas_radps[i] < 0 ? 1 : 0; break;
          case Quantity::kValid: x = valid ? 1 : 0; break;
          case Quantity::kLatAccel: x = valid ? s.a_y_meas_mps2[i] : 0.0; break;
          case Quantity::kLongAccel: x = valid ? s.a_x_meas_mps2[i] : 0.0; break;
          case Quantity::kYawRate: x = valid ? s.yaw_rate_meas_radps[i] * kRadToDeg : 0.0; break;
          case Quantity::kEsp: x = s.esp_active[i]; break;
          case Quantity::kWheelFL: x = s.wheel_speed_meas_mps[0][i] * kMpsToKph; break;
          case Quantity::kWheelFR: x = s.wheel_speed_meas_mps[1][i] * kMpsToKph; break;
          case Quantity::kWheelRL: x = s.wheel_speed_meas_mps[2][i] * kMpsToKph; break;
          case Quantity::kWheelRR: x = s.wheel_speed_meas_mps[3][i] * kMpsToKph; break;
          case Quantity::kSpeed: x = s.speed_meas_mps[i] * kMpsToKph; break;
          case Quantity::kBrake: x = s.brake[i]; break;
          case Quantity::kEngineSpeed: x = 750.0 + 60.0 * v + 300.0 * std::max(0.0, s.a_x_mps2[i]); break;
          case Quantity::kEngineTorque:  // drive force (inertia + rolling + aero) at the wheel / overall ratio
            x = mass * (s.a_x_mps2[i] + 0.1 + 0.0004 * v * v) * 0.31 / 3.5;
            break;
          case Quantity::kPedal:
            x = std::clamp(mass * (s.a_x_mps2[i] + 0.1 + 0.0004 * v * v) * 0.31 / 3.5 / 2.5, 0.0, 100.0);
            break;
          case Quantity::kGear: x = s.gear[i]; break;
          case Quantity::kReverse: x = s.gear[i] == 1 ? 1 : 0; break;
          case Quantity::kOdometer: x = odometer_km; break;
          case Quantity::kAmbient: x = drive.ambient_temp_c; break;
          case Quantity::kBatteryVoltage: x = t < 1.5 ? 12.4 : 14.2 + 0.1 * std::sin(t / 30.0); break;
          case Quantity::kBatteryCurrent: x = t < 1.5 ? -40.0 : 8.0 + 4.0 * std::sin(t / 17.0); break;
          case Quantity::kCabinTemp:
            x = 21.0 + (drive.ambient_temp_c - 21.0) * std::exp(-t / 600.0);
            break;
          case Quantity::kFan: x = t < 600.0 ? 4 : 2; break;
          case Quantity::kAc: x = drive.ambient_temp_c > 18.0 ? 1 : 0; break;
          case Quantity::kCounter:
            x = static_cast<double>(p.counter % (sig.length >= 64 ? ~0ull : (1ull << sig.length)));
            break;
          case Quantity::kChecksum: checksum = &sig; continue;
        }
        dbc::EncodeSignal(sig, x * sp.scale, payload);
      }
      if (checksum) {  // XOR of bytes 0..6 (the checksum byte itself is 7)
        uint8_t c = 0;
        for (size_t b = 0; b + 1 < f.len; ++b) c ^= f.data[b];
        dbc::EncodeSignal(*checksum, c, payload);
      }
      ++p.counter;
      emit(ctx, f);
    }
  }
}

// Output file: plain stdio or zlib's gzip stream (a fixed header: no name, mtime 0).
struct CandumpLogWriter::Sink {
  std::string path;
  FILE* file = nullptr;
  gzFile gz = nullptr;
  std::string buffer;
  void Flush() {
    if (buffer.empty()) return;
    bool ok = true;
    if (gz) ok = gzwrite(gz, buffer.data(), static_cast<unsigned>(buffer.size())) == static_cast<int>(buffer.size());
    if (file) ok = std::fwrite(buffer.data(), 1, buffer.size(), file) == buffer.size();
    if (!ok) throw Error(path + ": write failed");
    buffer.clear();
  }
};

CandumpLogWriter::CandumpLogWriter(const dbc::Database& db, const config::SimulationConfig& cfg, const std::string& path)
    : encoder_(db, cfg), sink_(std::make_unique<Sink>()), bus_(cfg.bus_name) {
  sink_->path = path;
  const bool gzip = path.size() >= 3 && path.compare(path.size() - 3, 3, ".gz") == 0;
  if (gzip) {
    sink_->gz = gzopen(path.c_str(), "wb6");
    if (sink_->gz) gzbuffer(sink_->gz, 1 << 20);
  } else {
    sink_->file = std::fopen(path.c_str(), "wb");
  }
  if (!sink_->gz && !sink_->file) throw Error(path + ": cannot open for writing");
  sink_->buffer.reserve(1 << 21);
}

CandumpLogWriter::~CandumpLogWriter() {
  try {
    Close();
  } catch (...) {
  }
}

void CandumpLogWriter::WriteDrive(const DriveResult& drive) {
  encoder_.EncodeDrive(drive, [this](const can::CanFrame& f) {
    sink_->buffer += can::FormatCandumpLine(f, bus_);
    sink_->buffer += '\n';
    ++frames_;
    if (sink_->buffer.size() > (1u << 20)) sink_->Flush();
  });
}

void CandumpLogWriter::Close() {
  if (!sink_ || (!sink_->gz && !sink_->file)) return;
  sink_->Flush();
  bool ok = true;
  if (sink_->gz) ok = gzclose(sink_->gz) == Z_OK;
  if (sink_->file) ok = std::fclose(sink_->file) == 0;
  sink_->gz = nullptr;
  sink_->file = nullptr;
  if (!ok) throw Error(sink_->path + ": closing failed");
}

void WriteCandumpLog(const SimulationResult& result, const dbc::Database& db, const std::string& path) {
  CandumpLogWriter writer(db, result.config, path);
  for (const auto& d : result.drives) writer.WriteDrive(d);
  writer.Close();
}

}  // namespace ndsid::sim
