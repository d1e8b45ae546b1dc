// Yaw-rate sensor (gyro) offset: r_meas = r + r0 (physics.md §4; every real gyro has a few tenths
// of a deg/s, moving with temperature). Residual signature without it: a constant in the yaw-rate
// residual, and in a_y - v r_meas a term v r0 that grows with speed. The measured yaw rate the
// model reads as an input (the road_bank observer, the kinematic bank estimate) is corrected too:
// the bank is then tracked from v (r_meas - r0) - a_y,meas, so a bank cannot stand in for the
// offset (with road_bank and no gyro_offset the observer turns r0 into a bank v r0).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class GyroOffset final : public EffectImpl<GyroOffset> {
 public:
  GyroOffset()
      : EffectImpl({.name = "gyro_offset",
                    .description = "r_meas = r + r0 (yaw-rate sensor offset)",
                    .signature = "constant in the yaw-rate residual; v r0 in a_y - v r_meas; mean r at standstill",
                    .params = {{.name = "gyro_offset_radps", .unit = "rad/s", .lower = -0.03, .upper = 0.03, .initial = 0.0, .neutral = 0.0, .typical = 0.007}},
                    .num_states = 0,
                    .yaw_rate_sensor = true}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries& s, size_t k, ModelInputs<T>& u) const {
    if (!u.yaw_rate_measured) return;
    u.yaw_rate_meas_radps -= eta[0];
    u.bank_mps2 -= T(s.speed(k)) * eta[0];  // the bank estimate lowpass(v r_meas - a_y) used the raw r_meas
  }
  template <class T>
  T MeasureYawRateT(const T* eta, const MeasurementContext<T>&, const T*) const {
    return eta[0];
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeGyroOffset() { return std::make_shared<GyroOffset>(); }

}  // namespace ndsid::model
