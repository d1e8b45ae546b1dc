// Accelerometer bias: a_meas = a_y + b.  Residual signature without it: a constant (also at
// standstill). Identifiable from (d_sw, v, a_y). The box, +-2 m/s^2, is the sensor's own bias
// plus a mounting tilt of up to about 11 degrees about the longitudinal axis (g sin(tilt)): a
// logger's IMU on a bracket, not only a factory-calibrated ESC sensor.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class AccelBias final : public EffectImpl<AccelBias> {
 public:
  AccelBias()
      : EffectImpl({.name = "accel_bias",
                    .description = "a_meas = a_y + b",
                    .signature = "constant offset, also at standstill",
                    .params = {{.name = "accel_bias_mps2", .unit = "m/s^2",
                                .lower = -2.0, .upper = 2.0, .initial = 0.0, .neutral = 0.0, .typical = 0.1}},
                    .num_states = 0}) {}
  template <class T>
  T MeasureT(const T* eta, const MeasurementContext<T>&, const T*) const {
    return eta[0];
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeAccelBias() { return std::make_shared<AccelBias>(); }

}  // namespace ndsid::model
