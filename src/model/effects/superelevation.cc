// Superelevation: curves banked into the turn, bank e correlated with the curvature's sign.
// Gravity helps the turn: beta' += e g tanh(r / 0.02 rad/s) / v. Biases EG (the tyres work
// less for the same a_y); with yaw rate identifiable, without only through v-dependence.
#include "builtin_effects.h"

#include <cmath>

namespace ndsid::model {
namespace {

class Superelevation final : public EffectImpl<Superelevation> {
 public:
  Superelevation()
      : EffectImpl({.name = "superelevation",
                    .description = "beta' += e g tanh(r / 0.02) / v (bank into the curve)",
                    .signature = "odd in a_y at low a_y, saturating: biases EG",
                    .params = {{.name = "superelevation", .unit = "-",
                                .lower = 0.0, .upper = 0.1, .initial = 0.0, .neutral = 0.0, .typical = 0.04}},
                    .num_states = 0}) {}
  template <class T>
  void ForcesT(const T* eta, const Params<T>&, double, const AxleSlip<T>&, const State<T>& x, const ModelInputs<T>&,
               const T*, ForceTerms<T>& f) const {
    using std::tanh;
    f.gravity_lat_mps2 += eta[0] * T(kGravity_mps2) * tanh(x.r / T(0.02));
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeSuperelevation() { return std::make_shared<Superelevation>(); }

}  // namespace ndsid::model
