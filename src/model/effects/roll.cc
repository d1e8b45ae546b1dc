// Body roll seen by the body-fixed accelerometer: a_meas = a_y + g phi, with the roll angle
// following a second-order roll mode driven by the lateral acceleration:
//   phi'' = w^2 (k_phi a_y - phi) - 2 zeta w phi',  w = 2 pi 1.5 Hz, zeta = 0.5
// Steady part (g k_phi a_y) trades with `is` / EG from (d_sw, v, a_y) alone; yaw rate or the
// roll mode's lag separate it. States: phi, phi'.
#include "builtin_effects.h"

#include <cmath>

namespace ndsid::model {
namespace {

constexpr double kRollOmega = 2 * M_PI * 1.5;  // rad/s
constexpr double kRollZeta = 0.5;

class Roll final : public EffectImpl<Roll> {
 public:
  Roll()
      : EffectImpl({.name = "roll",
                    .description = "a_meas = a_y + g phi, phi'' = w^2 (k_phi a_y - phi) - 2 zeta w phi' (1.5 Hz, zeta 0.5)",
                    .signature = "proportional to a_y, lagging; confounded with is/EG in steady state",
                    .params = {{.name = "roll_gradient_rad_per_mps2", .unit = "rad/(m/s^2)",
                                .lower = 0.0, .upper = 0.03, .initial = 0.0, .neutral = 0.0, .typical = 0.0089}},
                    .num_states = 2}) {}
  template <class T>
  T MeasureT(const T*, const MeasurementContext<T>&, const T* st) const {
    return T(kGravity_mps2) * st[0];
  }
  template <class T>
  void InitStatesT(const T* eta, const Params<T>&, double, const ModelInputs<T>&, const State<T>&, T a_y,
                   T* st) const {
    st[0] = eta[0] * a_y;
    st[1] = T(0.0);
  }
  template <class T>
  void AdvanceStatesT(const T* eta, const Params<T>&, double, const ModelInputs<T>&, const ModelInputs<T>&,
                      const State<T>&, const State<T>&, T a_y0, double dt, T* st) const {
    // Semi-implicit Euler in 4 sub-steps (w dt/4 ~ 0.05): stable and accurate for the 1.5 Hz mode.
    const double h = dt / 4;
    for (int i = 0; i < 4; ++i) {
      st[1] += T(h) * (T(kRollOmega * kRollOmega) * (eta[0] * a_y0 - st[0]) - T(2 * kRollZeta * kRollOmega) * st[1]);
      st[0] += T(h) * st[1];
    }
  }
};

}  // namespace

std::shared_ptr<const Effect> MakeRoll() { return std::make_shared<Roll>(); }

}  // namespace ndsid::model
