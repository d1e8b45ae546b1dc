// Accelerometer ahead of the CG by x_s: a_meas = a_y + x_s r'. Signature: correlates with yaw
// acceleration, zero in steady state. Identifiable from the dynamics.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class LeverArm final : public EffectImpl<LeverArm> {
 public:
  LeverArm()
      : EffectImpl({"lever_arm", "a_meas = a_y + x_s r'", "correlates with yaw acceleration, zero in steady state",
                    {{"lever_arm_m", "m", -2.0, 2.0, 0.0, 0.0, 0.8}}, 0}) {}
  template <class T>
  T MeasureT(const T* eta, const MeasurementContext<T>& m, const T*) const {
    return eta[0] * m.yaw_accel;
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeLeverArm() { return std::make_shared<LeverArm>(); }

}  // namespace ndsid::model
