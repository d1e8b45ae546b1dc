// Steering-angle offset at the steering wheel: d_sw,true = d_sw,meas - d0. Signature: grows
// with v^2 on straights, ~ -(d0/is) v^2/(l + EG v^2). Identifiable from (d_sw, v, a_y).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class SteerOffset final : public EffectImpl<SteerOffset> {
 public:
  SteerOffset()
      : EffectImpl({.name = "steer_offset",
                    .description = "d_sw,true = d_sw,meas - d0 (at the steering wheel)",
                    .signature = "grows with v^2 on straights: -(d0/is) v^2/(l + EG v^2)",
                    .params = {{.name = "steer_offset_rad", .unit = "rad",
                                .lower = -0.1, .upper = 0.1, .initial = 0.0, .neutral = 0.0, .typical = 0.026}},
                    .num_states = 0}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries&, size_t, ModelInputs<T>& u) const {
    u.steer_rad -= eta[0];
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeSteerOffset() { return std::make_shared<SteerOffset>(); }

}  // namespace ndsid::model
