// Writes a small candump log of the example bus (dbc/ndsid_example.dbc) for the daemon tests:
// drives of a car that follows the linear single-track model (ndsid::model, the one model the
// identifier fits) exactly, with known parameters, noisy sensors and the DBC's quantisation.
// Each drive: 5 s standstill on a cross-slope (a_y = 0.12 m/s^2), a speed ramp, then a
// steering excitation at 11..25 m/s. Drives are separated by a bus silence of 120 s.
//
//   ndsid_daemon_make_log OUT.log [drives=3] [drive_s=300] [seed=1]
// Prints the true EG [rad/(m/s^2)] on stdout.
#include <cmath>
#include <cstdio>
#include <cstdlib>
#include <random>
#include <string>

#include "ndsid/can/candump_reader.h"
#include "ndsid/dbc/dbc_parser.h"
#include "ndsid/dbc/encoder.h"
#include "ndsid/model/simulate.h"

namespace {

using ndsid::can::CanFrame;
using ndsid::dbc::Database;
using ndsid::dbc::Message;

constexpr double kWheelbase_m = 2.648;
constexpr double kDt_s = 0.01;               // simulation step = fastest message cycle
constexpr double kCrossSlope_mps2 = 0.12;    // a_y at standstill
constexpr int64_t kStart_ns = 1'700'000'000'000'000'000;
constexpr double kDriveGap_s = 120;

const ndsid::model::Params<double> kTruth{1900, 2700, 78000, 122000, 1.15, 14.8};

struct Writer {
  const Database& db;
  FILE* out;
  void Emit(const char* message, int64_t t_ns, std::initializer_list<std::pair<const char*, double>> values) {
    const Message* m = db.FindMessage(message);
    if (!m) throw std::runtime_error(std::string("DBC lacks ") + message);
    CanFrame f;
    f.timestamp_ns = t_ns;
    f.id = m->id;
    f.flags = m->extended ? ndsid::can::kFlagExtended : 0;
    f.len = static_cast<uint8_t>(m->length);
    for (const auto& [name, value] : values) {
      const auto* s = m->FindSignal(name);
      if (!s) throw std::runtime_error(std::string("DBC lacks ") + message + "." + name);
      ndsid::dbc::EncodeSignal(*s, value, std::span<uint8_t>(f.data.data(), f.len));
    }
    std::fprintf(out, "%s\n", ndsid::can::FormatCandumpLine(f, "can0").c_str());
  }
};

}  // namespace

int main(int argc, char** argv) {
  if (argc < 2) {
    std::fprintf(stderr, "usage: %s OUT.log [drives] [drive_s] [seed]\n", argv[0]);
    return 2;
  }
  const int drives = argc > 2 ? std::atoi(argv[2]) : 3;
  const double drive_s = argc > 3 ? std::atof(argv[3]) : 300;
  const unsigned seed = argc > 4 ? static_cast<unsigned>(std::atoi(argv[4])) : 1;
  const Database db = ndsid::dbc::ParseDbcFile(std::string(NDSID_SOURCE_DIR) + "/dbc/ndsid_example.dbc");
  FILE* out = std::fopen(argv[1], "w");
  if (!out) {
    std::perror(argv[1]);
    return 1;
  }
  Writer w{db, out};
  std::mt19937_64 rng(seed);
  std::normal_distribution<double> n01(0.0, 1.0);
  std::uniform_real_distribution<double> phase(0.0, 2 * M_PI);
  const double eg = ndsid::model::SelfSteerGradient(kTruth, kWheelbase_m);

  int64_t t0_ns = kStart_ns;
  for (int d = 0; d < drives; ++d) {
    const double p1 = phase(rng), p2 = phase(rng), p3 = phase(rng), pv = phase(rng);
    ndsid::model::State<double> x{0, 0};
    bool dynamic = false;
    double prev_steer = 0, prev_v = 0;
    const int steps = static_cast<int>(drive_s / kDt_s);
    for (int k = 0; k < steps; ++k) {
      const double t = k * kDt_s;
      const int64_t t_ns = t0_ns + static_cast<int64_t>(std::llround(t * 1e9));
      // Speed: standstill 5 s, ramp to 18 m/s over 10 s, then 18 +- 7 m/s.
      double v = 0;
      if (t >= 5 && t < 15) v = 1.8 * (t - 5);
      if (t >= 15) v = 18 + 7 * std::sin(2 * M_PI * (t - 15) / 120 + pv) * std::min(1.0, (t - 15) / 20);
      // Steering: a target lateral acceleration mapped through the steady-state gain.
      double steer = 0, ay = 0, r = 0;
      if (t >= 15) {
        const double ramp = std::min(1.0, (t - 15) / 5);
        const double a_target = ramp * (1.8 * std::sin(2 * M_PI * 0.045 * t + p1) + 0.7 * std::sin(2 * M_PI * 0.21 * t + p2) +
                                        0.25 * std::sin(2 * M_PI * 0.8 * t + p3));
        steer = a_target * kTruth.is * (kWheelbase_m + eg * v * v) / (v * v);
        if (!dynamic) {
          x = ndsid::model::SteadyState(kTruth, kWheelbase_m, steer, v);
          dynamic = true;
        } else {
          ndsid::model::Rk4Step(kTruth, kWheelbase_m, x, prev_steer, steer, prev_v, v, kDt_s);
        }
        ay = ndsid::model::LinearDerivative(kTruth, kWheelbase_m, x, steer, v).a_y;
        r = x.r;
      } else if (v == 0) {
        ay = kCrossSlope_mps2;
      }
      prev_steer = steer;
      prev_v = v;
      const double ay_meas = ay + 0.04 * n01(rng);
      const double r_meas_degps = (r + 0.002 * n01(rng)) * 180 / M_PI;
      w.Emit("STEERING_SENSOR", t_ns + 1'000'000, {{"SteeringWheelAngle", steer * 180 / M_PI}, {"SteeringAngleValid", 1}});
      w.Emit("ESP_DYNAMICS", t_ns + 3'000'000,
             {{"LateralAcceleration", ay_meas}, {"YawRate", r_meas_degps}, {"LongitudinalAcceleration", 0},
              {"DynamicsValid", 1}, {"EspIntervention", 0}});
      if (k % 2 == 0) w.Emit("VEHICLE_SPEED", t_ns + 5'000'000, {{"VehicleSpeed", v * 3.6}});
      if (k % 10 == 0) w.Emit("VEHICLE_STATUS", t_ns + 7'000'000, {{"StatusPage", 0}, {"GearPosition", 3}, {"ReverseGear", 0}});
    }
    t0_ns += static_cast<int64_t>((drive_s + kDriveGap_s) * 1e9);
  }
  if (std::fclose(out) != 0) {
    std::perror(argv[1]);
    return 1;
  }
  std::printf("%.9e\n", eg);
  return 0;
}
