// Accelerometer scale error: a_meas = (1 + k_a) a_y (physics.md §4). Residual signature without
// it: proportional to a_y. From (d_sw, v, a_y) alone it trades with the steering ratio `is` (and
// with roll's steady part); with the yaw rate as an output the kinematic a_y = v r fixes it, so
// it is not a default candidate of the a_y-only diagnosis. The scale applies to the modelled CG
// acceleration; the other measurement terms (bias, lever arm, roll) are added unscaled (their
// product with k_a is second order).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class AccelScale final : public EffectImpl<AccelScale> {
 public:
  AccelScale()
      : EffectImpl({.name = "accel_scale",
                    .description = "a_meas = (1 + k_a) a_y (accelerometer scale error)",
                    .signature = "proportional to a_y; confounded with is from a_y alone, separated by the yaw rate (a_y = v r)",
                    .params = {{.name = "accel_scale", .unit = "-", .lower = -0.1, .upper = 0.1, .initial = 0.0, .neutral = 0.0, .typical = 0.03}},
                    .num_states = 0,
                    .needs_yaw_rate_output = true}) {}
  template <class T>
  T MeasureT(const T* eta, const MeasurementContext<T>& m, const T*) const {
    return eta[0] * m.a_y;
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeAccelScale() { return std::make_shared<AccelScale>(); }

}  // namespace ndsid::model
