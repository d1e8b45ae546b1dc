// Speed scale error (tyre radius): v_meas = (1 + eps) v. Signature: in the Ackermann term,
// ~ -2 eps a_y l/(l + EG v^2); trades with l/is (weakly identifiable).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class SpeedScale final : public EffectImpl<SpeedScale> {
 public:
  SpeedScale()
      : EffectImpl({"speed_scale", "v_true = v_meas / (1 + eps)", "odd in a_y, ~ -2 eps a_y l/(l + EG v^2)",
                    {{"speed_scale", "-", -0.08, 0.08, 0.0, 0.0, 0.03}}, 0}) {}
  template <class T>
  void InputsT(const T* eta, const InputSeries&, size_t, ModelInputs<T>& u) const {
    u.speed_mps /= (T(1.0) + eta[0]);
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeSpeedScale() { return std::make_shared<SpeedScale>(); }

}  // namespace ndsid::model
