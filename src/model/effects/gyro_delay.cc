// Yaw-rate sensor latency: the gyro's value reaches the bus tau later than the accelerometer's
// (sensor filtering, a slower message): r_meas(t) = r(t - tau), an exact delay of the modelled
// yaw rate, read from its recent history by linear interpolation (a first-order form r - tau r'
// underestimates tau by 10-25 % on driving data: its gain grows with frequency). Signature: the
// yaw-rate residual follows r' (the yaw acceleration) at all speeds; a_y is untouched.
// With the yaw rate as the second output this is the relative latency: a latency shared by a_y
// and the yaw rate is steer_delay's (a time skew of the inputs), so steer_delay + gyro_delay span
// every pair of output latencies. A negative tau (the gyro ahead of the accelerometer) uses the
// first-order form r - tau r' (the model's future is not known at sample k).
// The measured yaw rate the model reads as an input (road_bank's observer, the kinematic bank
// estimate) is read tau later, realigned with the model's time.
// States: [0] the step dt (0 before the first step), [1] the ring's newest slot, [2..] the ring of
// the modelled yaw rate at the previous kSlots samples. Delays beyond kSlots samples are held at
// the oldest (kSlots * dt: 0.64 s at the default 50 Hz fit rate, 0.32 s at 100 Hz).
#include "builtin_effects.h"

#include <algorithm>
#include <cmath>

namespace ndsid::model {
namespace {

constexpr int kSlots = 32;

class GyroDelay final : public EffectImpl<GyroDelay> {
 public:
  GyroDelay()
      : EffectImpl({.name = "gyro_delay",
                    .description = "r_meas(t) = r(t - tau) (yaw-rate sensor latency)",
                    .signature = "yaw-rate residual proportional to the yaw acceleration r', at all speeds",
                    .params = {{.name = "gyro_delay_s", .unit = "s", .lower = -0.1, .upper = 0.3, .initial = 0.0,
                                .neutral = 0.0, .typical = 0.05}},
                    .num_states = 2 + kSlots,
                    .yaw_rate_sensor = true,
                    .needs_yaw_rate_output = true}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries& s, size_t k, ModelInputs<T>& u) const {
    if (!u.yaw_rate_measured || s.yaw_rate_radps == nullptr) return;
    // Added as the change the shift makes, so that gyro_offset's correction is kept.
    const T change = s.YawRate(T(static_cast<double>(k)) + eta[0] / T(s.dt_s)) - T(s.yaw_rate(k));
    u.yaw_rate_meas_radps += change;
    u.bank_mps2 += T(s.speed(k)) * change;  // lowpass(v r_meas - a_y) read the unshifted r_meas
  }
  template <class T>
  T MeasureYawRateT(const T* eta, const MeasurementContext<T>& m, const T* st) const {
    const double dt = ScalarOf(st[0]);
    if (!(dt > 0) || !(ScalarOf(eta[0]) > 0)) return -eta[0] * m.yaw_accel;  // first sample, or an advance
    const int head = static_cast<int>(ScalarOf(st[1]));
    // i samples back: i = 0 is now, i >= 1 from the ring (i = 1 the newest slot).
    auto back = [&](int i) -> T { return i == 0 ? m.yaw_rate : st[2 + ((head - (i - 1)) % kSlots + kSlots) % kSlots]; };
    const T pos = eta[0] / T(dt);
    const double p0 = std::min(std::floor(ScalarOf(pos)), static_cast<double>(kSlots - 1));
    const int i = static_cast<int>(p0);
    const T w = std::min(ScalarOf(pos), static_cast<double>(kSlots)) == ScalarOf(pos) ? pos - T(p0) : T(1.0);
    return back(i) + w * (back(i + 1) - back(i)) - m.yaw_rate;
  }
  template <class T>
  void InitStatesT(const T*, const Params<T>&, double, const ModelInputs<T>&, const State<T>& x, T, T* st) const {
    st[0] = T(0.0);
    st[1] = T(0.0);
    for (int j = 0; j < kSlots; ++j) st[2 + j] = x.r;  // the start is a steady state
  }
  template <class T>
  void AdvanceStatesT(const T*, const Params<T>&, double, const ModelInputs<T>&, const ModelInputs<T>&,
                      const State<T>& x0, const State<T>&, T, double dt, T* st) const {
    const int head = (static_cast<int>(ScalarOf(st[1])) + 1) % kSlots;
    st[2 + head] = x0.r;  // r at the sample just left: one sample back from the next
    st[1] = T(static_cast<double>(head));
    st[0] = T(dt);
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeGyroDelay() { return std::make_shared<GyroDelay>(); }

}  // namespace ndsid::model
