// Accelerometer ahead of the CG by x_s: a_meas = a_y + x_s r'. Signature: correlates with yaw
// acceleration, zero in steady state. Identifiable from the dynamics.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class LeverArm final : public EffectImpl<LeverArm> {
 public:
  LeverArm()
      : EffectImpl({.name = "lever_arm",
                    .description = "a_meas = a_y + x_s r'",
                    .signature = "correlates with yaw acceleration, zero in steady state",
                    .params = {{.name = "lever_arm_m", .unit = "m",
                                .lower = -2.0, .upper = 2.0, .initial = 0.0, .neutral = 0.0, .typical = 0.8}},
                    .num_states = 0}) {}
  template <class T>
  T MeasureT(const T* eta, const MeasurementContext<T>& m, const T*) const {
    return eta[0] * m.yaw_accel;
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeLeverArm() { return std::make_shared<LeverArm>(); }

}  // namespace ndsid::model
