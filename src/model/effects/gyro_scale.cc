// Yaw-rate sensor (gyro) scale error: r_meas = (1 + k_r) r (physics.md §4). Residual signature
// without it: proportional to r in the yaw-rate residual; in a_y - v r_meas a term -k_r v r.
// With a_y alone it is invisible except through the road_bank observer, which reads the yaw rate;
// with the yaw rate as an output the kinematic a_y = v r separates it from the steering ratio.
// The measured yaw rate the model reads as an input is corrected as for gyro_offset (applied
// after it: r = (r_meas - r0) / (1 + k_r)).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class GyroScale final : public EffectImpl<GyroScale> {
 public:
  GyroScale()
      : EffectImpl({.name = "gyro_scale",
                    .description = "r_meas = (1 + k_r) r (yaw-rate sensor scale error)",
                    .signature = "proportional to r in the yaw-rate residual; -k_r v r in a_y - v r_meas",
                    .params = {{.name = "gyro_scale", .unit = "-", .lower = -0.1, .upper = 0.1, .initial = 0.0, .neutral = 0.0, .typical = 0.03}},
                    .num_states = 0,
                    .yaw_rate_sensor = true}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries& s, size_t k, ModelInputs<T>& u) const {
    if (!u.yaw_rate_measured) return;
    const T excess = u.yaw_rate_meas_radps * eta[0] / (T(1.0) + eta[0]);  // r_meas - r_meas / (1 + k)
    u.yaw_rate_meas_radps -= excess;
    u.bank_mps2 -= T(s.speed(k)) * excess;
  }
  template <class T>
  T MeasureYawRateT(const T* eta, const MeasurementContext<T>& m, const T*) const {
    return eta[0] * m.yaw_rate;
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeGyroScale() { return std::make_shared<GyroScale>(); }

}  // namespace ndsid::model
