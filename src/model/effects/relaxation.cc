// Tyre relaxation length sigma: each axle's slip angle lags the kinematic one with
// tau = sigma / v. Carried as the deviation d = a_kin - a_used, exact for a slip changing
// linearly over a step:  d1 = d0 e^(-dt/tau) + (a_kin1 - a_kin0) (tau/dt) (1 - e^(-dt/tau)).
// sigma -> 0 gives d = 0 (the base model). Signature: correlates with steering rate, more so
// at low speed. States: d_front, d_rear.
#include "builtin_effects.h"

#include <cmath>

namespace ndsid::model {
namespace {

class Relaxation final : public EffectImpl<Relaxation> {
 public:
  Relaxation()
      : EffectImpl({.name = "relaxation",
                    .description = "slip lag tau = sigma / v per axle (first-order)",
                    .signature = "correlates with steering rate, stronger at low speed",
                    .params = {{.name = "relaxation_length_m", .unit = "m",
                                .lower = 0.001, .upper = 3.0, .initial = 0.3, .neutral = 0.001, .typical = 0.6}},
                    .num_states = 2}) {}
  template <class T>
  void ForcesT(const T*, const Params<T>& p, double, const AxleSlip<T>& slip, const State<T>&, const ModelInputs<T>&,
               const T* st, ForceTerms<T>& f) const {
    f.force_front_n = p.cv * (slip.front - st[0]);
    f.force_rear_n = p.ch * (slip.rear - st[1]);
  }
  template <class T>
  void InitStatesT(const T*, const Params<T>&, double, const ModelInputs<T>&, const State<T>&, T, T* st) const {
    st[0] = T(0.0);
    st[1] = T(0.0);
  }
  template <class T>
  void AdvanceStatesT(const T* eta, const Params<T>& p, double l, const ModelInputs<T>& u0, const ModelInputs<T>& u1,
                      const State<T>& x0, const State<T>& x1, T, double dt, T* st) const {
    using std::exp;
    const AxleSlip<T> a0 = SlipAngles(p, l, x0, u0.steer_rad, u0.speed_mps);
    const AxleSlip<T> a1 = SlipAngles(p, l, x1, u1.steer_rad, u1.speed_mps);
    const T tau = eta[0] / (T(0.5) * (u0.speed_mps + u1.speed_mps));
    const T decay = exp(-T(dt) / tau);
    const T gain = tau / T(dt) * (T(1.0) - decay);
    st[0] = st[0] * decay + (a1.front - a0.front) * gain;
    st[1] = st[1] * decay + (a1.rear - a0.rear) * gain;
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeRelaxation() { return std::make_shared<Relaxation>(); }

}  // namespace ndsid::model
