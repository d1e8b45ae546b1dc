// Speed scale error (tyre radius): v_meas = (1 + eps) v. Signature: in the Ackermann term,
// ~ -2 eps a_y l/(l + EG v^2); trades with l/is (weakly identifiable).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class SpeedScale final : public EffectImpl<SpeedScale> {
 public:
  SpeedScale()
      : EffectImpl({.name = "speed_scale",
                    .description = "v_true = v_meas / (1 + eps)",
                    .signature = "odd in a_y, ~ -2 eps a_y l/(l + EG v^2)",
                    .params = {{.name = "speed_scale", .unit = "-",
                                .lower = -0.08, .upper = 0.08, .initial = 0.0, .neutral = 0.0, .typical = 0.03}},
                    .num_states = 0}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries&, size_t, ModelInputs<T>& u) const {
    u.speed_mps /= (T(1.0) + eta[0]);
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeSpeedScale() { return std::make_shared<SpeedScale>(); }

}  // namespace ndsid::model
