#include "ndsid/sync/lowpass.h"

#include <cmath>
#include <complex>

#include "ndsid/common/error.h"

namespace ndsid::sync {
namespace {
// The analogue prototype with unit group delay at zero frequency, H(s) = 3 / (s^2 + 3 s + 3),
// is 3 dB down at this angular frequency.
constexpr double kBessel2CutoffAtUnitDelay = 1.3616541287161306;
}  // namespace

BesselLowPass::BesselLowPass(double cutoff_hz, double rate_hz) : enabled_(true), rate_hz_(rate_hz) {
  if (!(cutoff_hz > 0) || !(rate_hz > 0) || cutoff_hz > rate_hz / 4)
    throw Error("low-pass cutoff " + std::to_string(cutoff_hz) + " Hz needs 0 < cutoff <= rate/4 (" + std::to_string(rate_hz / 4) +
                " Hz)");
  // Analogue H(s) = 3 w0^2 / (s^2 + 3 w0 s + 3 w0^2) with its -3 dB point at the cutoff, mapped by
  // the bilinear transform pre-warped at the cutoff (so the cutoff stays where it was asked).
  const double wc = 2 * M_PI * cutoff_hz;
  const double w0 = wc / kBessel2CutoffAtUnitDelay;
  const double k = wc / std::tan(wc / (2 * rate_hz));
  const double a = 3 * w0 * w0, b = 3 * w0;
  const double d0 = k * k + b * k + a, d1 = 2 * a - 2 * k * k, d2 = k * k - b * k + a;
  b0_ = a / d0, b1_ = 2 * a / d0, b2_ = a / d0;
  a1_ = d1 / d0, a2_ = d2 / d0;
  // Group delay at zero frequency of N(z)/D(z) in samples: sum k n_k / sum n_k - sum k d_k / sum d_k.
  const double num = (b1_ + 2 * b2_) / (b0_ + b1_ + b2_);
  const double den = (a1_ + 2 * a2_) / (1 + a1_ + a2_);
  delay_s_ = (num - den) / rate_hz;
}

double BesselLowPass::Step(double x) noexcept {
  if (!enabled_) return x;
  if (!primed_) {  // at rest on x: y = x for a constant input
    x1_ = x2_ = y1_ = y2_ = x;
    primed_ = true;
  }
  const double y = b0_ * x + b1_ * x1_ + b2_ * x2_ - a1_ * y1_ - a2_ * y2_;
  x2_ = x1_, x1_ = x, y2_ = y1_, y1_ = y;
  return y;
}

double BesselLowPass::Gain(double f_hz) const {
  if (!enabled_) return 1;
  const std::complex<double> z1 = std::polar(1.0, -2 * M_PI * f_hz / rate_hz_);
  const std::complex<double> n = b0_ + b1_ * z1 + b2_ * z1 * z1;
  const std::complex<double> d = 1.0 + a1_ * z1 + a2_ * z1 * z1;
  return std::abs(n / d);
}

}  // namespace ndsid::sync
