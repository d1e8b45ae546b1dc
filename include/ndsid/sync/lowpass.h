// Signal conditioning (signals.<role>.lowpass_hz): a causal second-order Bessel low-pass on the
// sync grid, for roles whose sensor is noisier than the dynamics it carries (a raw, vibrating
// IMU). Bessel because its group delay is flat across the pass band: the signal is delayed by one
// known time, which the sync stage takes back by reading the role that much later, so the
// filtered signal stays aligned with the others and the model and step 0 see no latency. The
// same filter runs live and in replay (one code path); docs/configuration.md, "Conditioning".
#pragma once

namespace ndsid::sync {

class BesselLowPass {
 public:
  BesselLowPass() = default;
  // cutoff_hz: the -3 dB frequency; rate_hz: the grid's sample rate. Needs 0 < cutoff <= rate/4.
  BesselLowPass(double cutoff_hz, double rate_hz);

  // Group delay at zero frequency [s]: the delay of everything well inside the pass band.
  double delay_s() const { return delay_s_; }
  bool enabled() const { return enabled_; }

  // One grid sample in, the filtered one out. The first sample after Reset() starts the filter at
  // rest on that value (no transient from zero).
  double Step(double x) noexcept;
  void Reset() noexcept { primed_ = false; }

  // |H| at frequency f [Hz] (for the docs' table and the tests).
  double Gain(double f_hz) const;

 private:
  bool enabled_ = false;
  bool primed_ = false;
  double rate_hz_ = 0;
  double b0_ = 1, b1_ = 0, b2_ = 0, a1_ = 0, a2_ = 0;  // y = b0 x + b1 x1 + b2 x2 - a1 y1 - a2 y2
  double x1_ = 0, x2_ = 0, y1_ = 0, y2_ = 0;
  double delay_s_ = 0;
};

}  // namespace ndsid::sync
