// Road bank (crossfall and superelevation together) measured by the yaw rate: the kinematic
// residual v r - a_y,meas ~ g sin(theta) (physics.md §4: "with r: v*r - a_meas"), low-passed,
// enters the dynamics as gravity along the road: beta' += k g sin(theta) / v. The gain k
// (1 = the bank exactly as measured) is the parameter; 0 is the base model. Needs yaw rate.
// Without it, a driver counter-steering on cross-sloped straights biases EG low.
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

class RoadBank final : public EffectImpl<RoadBank> {
 public:
  RoadBank()
      : EffectImpl({"road_bank", "beta' += k * lowpass(v r - a_y,meas) / v (bank measured through the yaw rate)",
                    "low-frequency, per road; steering on straights without lateral acceleration",
                    {{"road_bank_gain", "-", 0.0, 1.5, 1.0, 0.0, 1.0}}, 0}) {}
  template <class T>
  void ForcesT(const T* eta, const Params<T>&, double, const AxleSlip<T>&, const State<T>&, const ModelInputs<T>& u,
               const T*, ForceTerms<T>& f) const {
    f.gravity_lat_mps2 += eta[0] * u.bank_mps2;
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeRoadBank() { return std::make_shared<RoadBank>(); }

}  // namespace ndsid::model
