// Yaw-rate sensor (gyro) offset: r_meas = r + r0 (physics.md §4; every real gyro has a few tenths
// of a deg/s, moving with temperature). Residual signature without it: a constant in the yaw-rate
// residual, and in a_y - v r_meas a term v r0 that grows with speed. The measured yaw rate the
// model reads as an input (the road_bank observer, the kinematic bank estimate) is corrected too:
// the bank is then tracked from v (r_meas - r0) - a_y,meas, so a bank cannot stand in for the
// offset (with road_bank and no gyro_offset the observer turns r0 into a bank v r0).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

// per_drive: gyro_offset_per_drive, the same term with one offset per drive (re-zeroed at every
// ignition, moving with temperature): the parameter vector holds the reference drive's offset,
// the identifier fits every other drive's (EffectParam::per_drive). Its parameter has the same
// name, so a model holds one of the two, and a fit of one warm-starts the other.
class GyroOffset final : public EffectImpl<GyroOffset> {
 public:
  explicit GyroOffset(bool per_drive)
      : EffectImpl({.name = per_drive ? "gyro_offset_per_drive" : "gyro_offset",
                    .description = per_drive ? "r_meas = r + r0_d (yaw-rate sensor offset, one per drive)"
                                             : "r_meas = r + r0 (yaw-rate sensor offset)",
                    .signature = per_drive ? "a constant in the yaw-rate residual that differs between drives"
                                           : "constant in the yaw-rate residual; v r0 in a_y - v r_meas; mean r at standstill",
                    .params = {{.name = "gyro_offset_radps", .unit = "rad/s", .lower = -0.03, .upper = 0.03, .initial = 0.0,
                                .neutral = 0.0, .typical = 0.007, .per_drive = per_drive}},
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

std::shared_ptr<const Effect> MakeGyroOffset() { return std::make_shared<GyroOffset>(false); }
std::shared_ptr<const Effect> MakeGyroOffsetPerDrive() { return std::make_shared<GyroOffset>(true); }

}  // namespace ndsid::model
