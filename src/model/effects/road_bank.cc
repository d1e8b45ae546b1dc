// Road bank (crossfall and superelevation together) tracked through the yaw rate. Gravity along
// a banked road acts on the body but not on the accelerometer: beta' += g sin(theta) / v. The
// bank's history is unknown, so the effect carries it as a state b driven by an observer that
// makes the model's yaw rate follow the measured one at low frequency:
//   b' = (r_meas - r_model) / (tau_o G(v)),   G(v) = v EG / (l + EG v^2)
// (G is the steady-state gain from a bank force to the yaw rate: r = v (delta + EG b) / L), and
// the force is k b. The loop closes with time constant tau_o / k; k = 0 is the base model. The
// gain is fitted (box 0..5): on the simulator's drives it settles at 2.2-2.5 (tau_o/k ~ 0.4 s),
// and EG does not depend on it (+0.04 % mean over 7 clean 2 h sims at a box of 0..5, +0.05 %
// with the fit stopped at 1.5).
// Why not simply b = lowpass(v r - a_y,meas) (physics.md §4: "with r: v*r - a_meas")? That puts
// the measured a_y (and its noise) into the model's input: the fit then tracks the measurement
// instead of predicting it, drifts in lv / cv and inherits the errors-in-variables bias of an
// equation-error fit (EG about -0.8 % on clean simulated drives, see docs/accuracy.md). The
// observer sees only the yaw rate, whose noise is independent of the accelerometer's, so sensor
// effects on a_y (bias, roll, lever arm) stay in the residual where the diagnosis can find them.
// The low-passed kinematic estimate only initialises b at a stretch's first sample. Needs yaw
// rate: without it b stays 0 and the effect is inert. The yaw rate it reads is the measurement as
// corrected by the model's gyro effects (gyro_offset, gyro_scale: r = (r_meas - r0)/(1 + k_r)),
// so with them in the model the bank cannot stand in for a gyro offset (docs/two-outputs.md).
#include "builtin_effects.h"

namespace ndsid::model {
namespace {

constexpr double kObserverTimeConstant_s = 1.0;
constexpr double kMinEg_radpmps2 = 1e-3;  // gain floor: a near-neutral car hides the bank from r

class RoadBank final : public EffectImpl<RoadBank> {
 public:
  RoadBank()
      : EffectImpl({.name = "road_bank",
                    .description = "beta' += k b / v, b' = (r_meas - r) / (tau_o G(v)): road bank tracked through the yaw rate",
                    .signature = "low-frequency, per road; steering on straights without lateral acceleration",
                    .params = {{.name = "road_bank_gain", .unit = "-",
                                .lower = 0.0, .upper = 5.0, .initial = 1.0, .neutral = 0.0, .typical = 1.0}},
                    .num_states = 1,
                    .reads_measured_yaw_rate = true}) {}
  template <class T>
  void ForcesT(const T* eta, const Params<T>&, double, const AxleSlip<T>&, const State<T>&, const ModelInputs<T>&,
               const T* states, ForceTerms<T>& f) const {
    f.gravity_lat_mps2 += eta[0] * states[0];
  }
  template <class T>
  void InitStatesT(const T*, const Params<T>&, double, const ModelInputs<T>& u, const State<T>&, T, T* states) const {
    states[0] = u.bank_mps2;
  }
  template <class T>
  void AdvanceStatesT(const T*, const Params<T>& p, double l, const ModelInputs<T>& u0, const ModelInputs<T>&,
                      const State<T>& x0, const State<T>&, T, double dt, T* states) const {
    if (!u0.yaw_rate_measured) return;  // no yaw rate on the bus: the bank stays at its start (0)
    T eg = SelfSteerGradient(p, l);
    if (ScalarOf(eg) < kMinEg_radpmps2) eg = T(kMinEg_radpmps2);
    const T v = u0.speed_mps;
    const T gain = v * eg / (l + eg * v * v);  // constants as doubles: the same values, less work
    states[0] += (u0.yaw_rate_meas_radps - x0.r) * dt / (gain * kObserverTimeConstant_s);
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeRoadBank() { return std::make_shared<RoadBank>(); }

}  // namespace ndsid::model
