// The car's sensors as the bus reports them (before DBC quantisation): the hidden sensor-side
// effects (bias, steering offset, roll and lever arm on the accelerometer, steering delay, speed
// scale, offset and latency, gyro offset and scale, the accelerometer's and the gyro's latency) plus white noise and a slow zero-mean accelerometer disturbance. Private to src/sim.
#pragma once

#include <array>
#include <cstdint>
#include <deque>
#include <vector>

#include "ndsid/config/simulation_config.h"
#include "ndsid/sim/random.h"
#include "ndsid/sim/simulator.h"

namespace ndsid::sim {

// The true state at one 100 Hz sample.
struct SampleTruth {
  double t, steer, v, a_y, r, r_dot, beta, a_x, roll, bank, kappa, s, e, e_target, psi;
  bool reverse;
};

class SensorModel {
 public:
  // vibration_seed: the stream of the vibration's tones (its own, so every other draw is the same
  // with and without vibration).
  SensorModel(const config::SimulationConfig& cfg, double dt_step_s, Rng& rng, uint64_t vibration_seed);
  void PushSteer(double steer_sw_rad);  // the true steering at every integration step
  void Record(const SampleTruth& truth, uint8_t gear, DriveSeries& out);

 private:
  double SteerAt(double t_s) const;  // true steering at t (linear interpolation, clamped)
  // The value recorded delay_s ago in a 100 Hz history (linear interpolation; the oldest kept
  // value before the history starts). Pushes `now` first; keeps the last kMaxDelaySamples.
  static double Delayed(std::deque<double>& history, double now, double delay_s);

  // A structural vibration: a few tones of random frequency (15..35 Hz) and phase, unit RMS
  // together; scaled by the effect's RMS while the car moves (rising to it by 5 m/s).
  struct Tone {
    double hz, phase_rad, amplitude;
  };
  using Tones = std::array<Tone, 4>;
  static Tones DrawTones(Rng& rng);
  static double Vibration(const Tones& tones, double t_s);

  const config::SimulationConfig& cfg_;
  double dt_step_s_;
  Rng& rng_;
  std::vector<double> steer_history_;
  std::deque<double> sensed_a_y_, sensed_r_, sensed_speed_;  // what the accelerometer, the gyro and the speed signal sense (latencies)
  OrnsteinUhlenbeck disturbance_;
  Tones accel_tones_{}, gyro_tones_{};  // the accelerometer's and the gyro's vibration
  double mu_esp_;
};

}  // namespace ndsid::sim
