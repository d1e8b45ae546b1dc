// Accelerometer bias: a_meas = a_y + b.  Residual signature without it: a constant (also at
// standstill). Identifiable from (d_sw, v, a_y).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class AccelBias final : public EffectImpl<AccelBias> {
 public:
  AccelBias()
      : EffectImpl({"accel_bias", "a_meas = a_y + b", "constant offset, also at standstill",
                    {{"accel_bias_mps2", "m/s^2", -0.5, 0.5, 0.0, 0.0, 0.1}}, 0}) {}
  template <class T>
  T MeasureT(const T* eta, const MeasurementContext<T>&, const T*) const {
    return eta[0];
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeAccelBias() { return std::make_shared<AccelBias>(); }

}  // namespace ndsid::model
