// Tyre saturation, to third order: F = c a - eta (c a)^3 / (3 Fz^2), eta = 1/mu^2, the series
// of F = mu Fz tanh(c a / (mu Fz)); Fz per axle from the static load (m g lh/l, m g lv/l).
// eta = 0 is the linear tyre. Signature: the model over-predicts at |a_y| > 3..4 m/s^2.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class TyreSaturation final : public EffectImpl<TyreSaturation> {
 public:
  TyreSaturation()
      : EffectImpl({.name = "tyre_saturation",
                    .description = "F = c a - (c a)^3 / (3 mu^2 Fz^2), parameter 1/mu^2",
                    .signature = "over-prediction growing like a_y^3",
                    .params = {{.name = "tyre_inv_mu_sq", .unit = "-",
                                .lower = 0.0, .upper = 4.0, .initial = 0.0, .neutral = 0.0, .typical = 1.23}},
                    .num_states = 0}) {}
  template <class T>
  void ForcesT(const T* eta, const Params<T>& p, double l, const AxleSlip<T>&, const State<T>&, const ModelInputs<T>&,
               const T*, ForceTerms<T>& f) const {
    const T g(kGravity_mps2);
    const T fz_front = p.m * g * (T(l) - p.lv) / T(l);
    const T fz_rear = p.m * g * p.lv / T(l);
    const T ff = f.force_front_n, fr = f.force_rear_n;
    f.force_front_n = ff - eta[0] * ff * ff * ff / (T(3.0) * fz_front * fz_front);
    f.force_rear_n = fr - eta[0] * fr * fr * fr / (T(3.0) * fz_rear * fz_rear);
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeTyreSaturation() { return std::make_shared<TyreSaturation>(); }

}  // namespace ndsid::model
