// Road crossfall (a constant bank over the data): gravity g_y = g sin(theta) acts on the body
// (beta' gains g_y/v) but the accelerometer senses only the tyre forces. Signature: even in
// a_y, -g_y l/(l + EG v^2) in steady state; at standstill the accelerometer reads -g_y.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class Crossfall final : public EffectImpl<Crossfall> {
 public:
  Crossfall()
      : EffectImpl({.name = "crossfall",
                    .description = "beta' += g_y / v (gravity along the banked road)",
                    .signature = "even in a_y: -g_y l/(l + EG v^2); standstill offset",
                    .params = {{.name = "crossfall_mps2", .unit = "m/s^2",
                                .lower = -0.6, .upper = 0.6, .initial = 0.0, .neutral = 0.0, .typical = 0.2}},
                    .num_states = 0}) {}
  template <class T>
  void ForcesT(const T* eta, const Params<T>&, double, const AxleSlip<T>&, const State<T>&, const ModelInputs<T>&,
               const T*, ForceTerms<T>& f) const {
    f.gravity_lat_mps2 += eta[0];
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeCrossfall() { return std::make_shared<Crossfall>(); }

}  // namespace ndsid::model
